/* The DARwIn-OP framework's start (ROBOTIS darwinop-ens/darwin-op: Linux/project/tutorial/
 * ball_following, MotionManager::Initialize, LinuxMotionTimer, CM730::TxRxPacket/BulkRead/
 * MakeBulkReadPacket, LinuxCM730), rewritten from the man pages and the Dynamixel Protocol 1.0
 * reference (shared/reference/dynamixel.md), bytes and threads as the framework makes them:
 *  - the port as LinuxCM730::OpenPort sets it up (B38400, TIOCGSERIAL, ASYNC_SPD_CUST with
 *    custom_divisor = baud_base / 1000000, TIOCSSERIAL, tcflush(TCIFLUSH));
 *  - Connect: WRITE Dynamixel Power (200, 24) = 1, WRITE the head LED word (200, 26), 300 ms;
 *    Initialize: READ Present Position (36, 2 bytes) of IDs 1..20;
 *  - a timer thread (SCHED_RR 31, explicit, as LinuxMotionTimer::Start) running every 8 ms
 *    (clock_nanosleep TIMER_ABSTIME): its first cycle PINGs 200, 112, 111 (MakeBulkReadPacket) and
 *    builds the BULK READ of those that answered (30 bytes from 24 of the CM-730, 10 from 26 of each
 *    FSR), every later cycle sends it;
 *  - meanwhile the main thread SYNC WRITEs Goal Position + Moving Speed of IDs 1..20 (address 30,
 *    4 bytes each: 108 bytes), as ball_following does right after motion_timer->Start();
 *  - every transaction as CM730::TxRxPacket: one semaphore for both threads, tcflush(TCIFLUSH),
 *    write, then a busy-poll of a non-blocking read() until the expected bytes arrived or
 *    12 us x bytes + 5 ms (BULK READ: x 1.5 its status bytes) passed since the write returned.
 * Usage: darwin_start DEVICE [--cycles N] [--margin-ms M] [--stall-doppel PID [--stall-ms S]].
 *   --margin-ms M: the M of 12 us x bytes + M (the framework's 5).
 *   --stall-doppel PID: before the main thread's SYNC WRITE and before each first-cycle PING, stop
 *   doppel (SIGSTOP, then wait until every thread of PID is stopped: no byte written after that
 *   can be read before it runs again) and have a resumer thread (SCHED_FIFO 80, above the timer
 *   thread and doppel's bus thread) continue it S ms (default 20) later, counting the resume just
 *   before its SIGCONT. A write() that returns only once doppel has read its bytes therefore sees that count;
 *   one that returns while doppel is stopped does not. This is what a loaded machine does by chance
 *   (doppel cannot read while the program writes and starts counting its read deadline), made to
 *   happen on purpose and on every run.
 * Prints:
 *   "initialize read=N of 20"
 *   "pings 200=ok 112=ok 111=ok bulk_reads answered=N of M"
 *   with --stall-doppel: "stalled writes sync_write=W ping200=W ping112=W ping111=W", W being
 *   after-resume (write() returned after doppel was continued) or while-stopped (before).
 * exit 0: the three PINGs were answered and a BULK READ returned all three statuses (a later
 * cycle that misses its timeout costs the robot one cycle, not a device) and, with
 * --stall-doppel, every stalled write returned after-resume;
 * 1: not; 2: a set-up step or an argument failed (named); 3: a real-time thread was refused (not
 * root). */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <pthread.h>
#include <sched.h>
#include <semaphore.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/time.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

enum { kPing = 1, kRead = 2, kWrite = 3, kSyncWrite = 0x83, kBulkRead = 0x92, kBroadcast = 0xFE };
enum { kCm730 = 200, kLeftFsr = 112, kRightFsr = 111 };

static int g_fd = -1;
static sem_t g_bus;  /* LinuxCM730's high-priority semaphore: one transaction at a time */
static unsigned char g_bulk[64];
static int g_bulk_devices = 0;
static int g_bulk_reply_bytes = 0;
static int g_ping_ok[3] = {0, 0, 0};
static int g_cycles = 60;
static int g_cycles_done = 0, g_bulk_sent = 0, g_bulk_complete = 0;
static double g_margin_ms = 5.0; /* CM730: 12 us x bytes + 5 ms */

/* --stall-doppel */
enum { kStallSyncWrite, kStallPing200, kStallPing112, kStallPing111, kStallPoints, kNoStall = -1 };
enum { kNotStalled, kAfterResume, kWhileStopped };
static const long kStopCheckNs = 100000;      /* between looks at doppel's threads (a sleep) */
static const double kStopLimitMs = 5000.0;    /* a doppel that does not stop by then is an error */
static pid_t g_doppel = 0;
static long g_stall_ns = 20000000; /* doppel stopped this long before it is continued */
static atomic_int g_stalls, g_resumes, g_quit;
static sem_t g_resume_request;
static int g_stall_result[kStallPoints];
static const char* volatile g_stall_error = NULL;

static double now_ms(void) {
  struct timeval tv;
  gettimeofday(&tv, NULL); /* LinuxCM730::GetCurrentTime */
  return tv.tv_sec * 1000.0 + tv.tv_usec / 1000.0;
}

static void packet(unsigned char* p, int id, int instruction, const unsigned char* params, int n) {
  unsigned char sum = 0;
  p[0] = 0xFF;
  p[1] = 0xFF;
  p[2] = (unsigned char)id;
  p[3] = (unsigned char)(n + 2);
  p[4] = (unsigned char)instruction;
  memcpy(p + 5, params, (size_t)n);
  for (int i = 2; i < n + 5; ++i) sum = (unsigned char)(sum + p[i]);
  p[n + 5] = (unsigned char)~sum;
}

static void pause_briefly(void) {
  const struct timespec pause = {0, kStopCheckNs};
  nanosleep(&pause, NULL);
}

/* 1 when every thread of doppel is stopped (or gone), 0 when one still runs, -1 when doppel is. */
static int doppel_stopped(void) {
  char path[64];
  snprintf(path, sizeof(path), "/proc/%d/task", (int)g_doppel);
  DIR* tasks = opendir(path);
  if (tasks == NULL) return -1;
  int stopped = 1;
  for (struct dirent* task = readdir(tasks); task != NULL && stopped; task = readdir(tasks)) {
    if (task->d_name[0] == '.') continue;
    char stat_path[sizeof(path) + sizeof(task->d_name) + 8], text[512];
    snprintf(stat_path, sizeof(stat_path), "%s/%s/stat", path, task->d_name);
    const int fd = open(stat_path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue; /* the thread ended meanwhile */
    const ssize_t n = read(fd, text, sizeof(text) - 1);
    close(fd);
    if (n <= 0) continue;
    text[n] = '\0';
    const char* name_end = strrchr(text, ')'); /* "tid (name) S ...": the name may hold anything */
    const char state = name_end != NULL && name_end[1] == ' ' ? name_end[2] : '?';
    if (state != 'T' && state != 'Z' && state != 'X') stopped = 0;
  }
  closedir(tasks);
  return stopped;
}

/* Stops doppel and asks the resumer to continue it g_stall_ns later; returns the stall's number. */
static int stall_doppel(void) {
  const int stall = atomic_load(&g_stalls) + 1;
  while (atomic_load(&g_resumes) < stall - 1) pause_briefly(); /* the last stall is over */
  if (kill(g_doppel, SIGSTOP) != 0) {
    g_stall_error = "SIGSTOP to doppel failed";
    return 0;
  }
  const double limit = now_ms() + kStopLimitMs;
  int stopped = 0;
  while ((stopped = doppel_stopped()) == 0 && now_ms() < limit) pause_briefly();
  if (stopped != 1) g_stall_error = stopped < 0 ? "doppel's /proc/PID/task is gone" : "doppel did not stop within 5 s";
  atomic_store(&g_stalls, stall);
  sem_post(&g_resume_request); /* continued in any case */
  return stall;
}

static void* resumer(void* arg) {
  (void)arg;
  for (;;) {
    while (sem_wait(&g_resume_request) != 0 && errno == EINTR) {
    }
    if (atomic_load(&g_quit)) return NULL;
    struct timespec left = {g_stall_ns / 1000000000, g_stall_ns % 1000000000};
    while (clock_nanosleep(CLOCK_MONOTONIC, 0, &left, &left) == EINTR) {
    }
    atomic_fetch_add(&g_resumes, 1); /* before SIGCONT: a write that waited for doppel sees it */
    kill(g_doppel, SIGCONT);
  }
}

/* One transaction; returns the bytes received (expected = what a complete answer holds). With
 * --stall-doppel and a stall point, doppel is stopped just before the write. */
static int transact(const unsigned char* tx, int length, unsigned char* rx, int expected, double timeout_ms, int stall_point) {
  while (sem_wait(&g_bus) != 0 && errno == EINTR) {
  }
  int got = 0;
  tcflush(g_fd, TCIFLUSH);
  const int stall = g_doppel != 0 && stall_point != kNoStall ? stall_doppel() : 0;
  const ssize_t written = write(g_fd, tx, (size_t)length);
  if (stall > 0) g_stall_result[stall_point] = atomic_load(&g_resumes) >= stall ? kAfterResume : kWhileStopped;
  if (written == length && expected > 0) {
    const double start = now_ms();
    while (got < expected) {
      const ssize_t n = read(g_fd, rx + got, (size_t)(expected - got));
      if (n > 0) got += (int)n;
      if (got < expected && now_ms() - start > timeout_ms) break;
    }
  }
  sem_post(&g_bus);
  return got;
}

static int status_ok(const unsigned char* rx, int n, int id) {
  unsigned char sum = 0;
  if (n < 6 || rx[0] != 0xFF || rx[1] != 0xFF || rx[2] != id || rx[3] + 4 != n) return 0;
  for (int i = 2; i < n - 1; ++i) sum = (unsigned char)(sum + rx[i]);
  return rx[n - 1] == (unsigned char)~sum;
}

static int ping(int id, int stall_point) {
  unsigned char tx[6], rx[6];
  packet(tx, id, kPing, NULL, 0);
  const int n = transact(tx, 6, rx, 6, 0.012 * 6 + g_margin_ms, stall_point);
  return status_ok(rx, n, id);
}

static void make_bulk_read(void) {
  static const int ids[3] = {kCm730, kLeftFsr, kRightFsr};
  static const int stall_points[3] = {kStallPing200, kStallPing112, kStallPing111};
  unsigned char params[1 + 9];
  int n = 0;
  params[n++] = 0x00;
  for (int k = 0; k < 3; ++k) {
    g_ping_ok[k] = ping(ids[k], stall_points[k]);
    if (!g_ping_ok[k]) continue;
    params[n++] = ids[k] == kCm730 ? 30 : 10;
    params[n++] = (unsigned char)ids[k];
    params[n++] = ids[k] == kCm730 ? 24 : 26;
    g_bulk_devices++;
    g_bulk_reply_bytes += (ids[k] == kCm730 ? 30 : 10) + 6;
  }
  packet(g_bulk, kBroadcast, kBulkRead, params, n);
}

static void bulk_read(void) {
  unsigned char rx[256];
  const int length = g_bulk[3] + 4;
  const int got = transact(g_bulk, length, rx, g_bulk_reply_bytes, 0.012 * g_bulk_reply_bytes * 1.5 + g_margin_ms, kNoStall);
  g_bulk_sent++;
  if (g_bulk_devices == 3 && got == g_bulk_reply_bytes && status_ok(rx, 36, kCm730) &&
      status_ok(rx + 36, 16, kLeftFsr) && status_ok(rx + 52, 16, kRightFsr)) {
    g_bulk_complete++;
  }
}

static void* timer(void* arg) {
  (void)arg;
  struct timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (g_cycles_done = 0; g_cycles_done < g_cycles; ++g_cycles_done) {
    next.tv_nsec += 8000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      next.tv_sec++;
    }
    if (g_bulk[3] == 0) {
      make_bulk_read(); /* CM730::BulkRead's first call: build it, send nothing (TX_FAIL) */
    } else {
      bulk_read();
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
  }
  return NULL;
}

static int failed(const char* step) {
  printf("%s failed: %s (errno %d)\n", step, strerror(errno), errno);
  return 2;
}

static int bad_argument(const char* option, const char* value, const char* expected) {
  printf("%s %s: expected %s\n", option, value ? value : "(missing)", expected);
  return 2;
}

/* A thread at `policy` `priority`, set explicitly (not inherited), as LinuxMotionTimer::Start asks. */
static int start_real_time(pthread_t* thread, int policy, int priority, void* (*routine)(void*)) {
  pthread_attr_t attr;
  struct sched_param param;
  pthread_attr_init(&attr);
  pthread_attr_setschedpolicy(&attr, policy);
  pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
  param.sched_priority = priority;
  pthread_attr_setschedparam(&attr, &param);
  const int error = pthread_create(thread, &attr, routine, NULL);
  pthread_attr_destroy(&attr);
  if (error != 0) {
    printf("the %s %d thread was refused: %s (run as root)\n", policy == SCHED_RR ? "SCHED_RR" : "SCHED_FIFO",
           priority, strerror(error));
  }
  return error;
}

int main(int argc, char** argv) {
  const char* device = argc > 1 ? argv[1] : "/dev/ttyUSB0";
  for (int i = 2; i < argc; i += 2) {
    const char* value = i + 1 < argc ? argv[i + 1] : NULL;
    char* end = NULL;
    if (strcmp(argv[i], "--cycles") == 0) {
      const long n = value ? strtol(value, &end, 10) : 0;
      if (value == NULL || *end != '\0' || n <= 0 || n > 100000) return bad_argument(argv[i], value, "a number of cycles, 1 to 100000");
      g_cycles = (int)n;
    } else if (strcmp(argv[i], "--margin-ms") == 0) {
      const double ms = value ? strtod(value, &end) : 0;
      if (value == NULL || *end != '\0' || !(ms > 0 && ms <= 60000)) return bad_argument(argv[i], value, "milliseconds, above 0 and at most 60000");
      g_margin_ms = ms;
    } else if (strcmp(argv[i], "--stall-doppel") == 0) {
      const long pid = value ? strtol(value, &end, 10) : 0;
      if (value == NULL || *end != '\0' || pid <= 1) return bad_argument(argv[i], value, "doppel's process id");
      g_doppel = (pid_t)pid;
      if (kill(g_doppel, 0) != 0) return failed("--stall-doppel: signalling that process");
    } else if (strcmp(argv[i], "--stall-ms") == 0) {
      const long ms = value ? strtol(value, &end, 10) : 0;
      if (value == NULL || *end != '\0' || ms <= 0 || ms > 1000) return bad_argument(argv[i], value, "milliseconds, 1 to 1000");
      g_stall_ns = ms * 1000000;
    } else {
      printf("unknown option %s (darwin_start DEVICE [--cycles N] [--margin-ms M] [--stall-doppel PID [--stall-ms S]])\n",
             argv[i]);
      return 2;
    }
  }
  setvbuf(stdout, NULL, _IOLBF, 0);
  sem_init(&g_bus, 0, 1);
  sem_init(&g_resume_request, 0, 0);
  pthread_t resumer_thread;
  if (g_doppel != 0 && start_real_time(&resumer_thread, SCHED_FIFO, 80, resumer) != 0) return 3;

  g_fd = open(device, O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (g_fd < 0) return failed("open");
  struct termios tio;
  memset(&tio, 0, sizeof(tio));
  tio.c_cflag = B38400 | CS8 | CLOCAL | CREAD;
  tio.c_iflag = IGNPAR;
  tcsetattr(g_fd, TCSANOW, &tio);
  struct serial_struct serinfo;
  if (ioctl(g_fd, TIOCGSERIAL, &serinfo) < 0) return failed("TIOCGSERIAL");
  serinfo.flags &= ~ASYNC_SPD_MASK;
  serinfo.flags |= ASYNC_SPD_CUST;
  serinfo.custom_divisor = (int)(serinfo.baud_base / 1000000.0);
  if (ioctl(g_fd, TIOCSSERIAL, &serinfo) < 0) return failed("TIOCSSERIAL");
  tcflush(g_fd, TCIFLUSH);

  /* CM730::Connect -> DXLPowerOn; MotionManager::Initialize's reads. */
  unsigned char tx[128], rx[64];
  const unsigned char power[] = {24, 1};
  packet(tx, kCm730, kWrite, power, 2);
  if (!status_ok(rx, transact(tx, 8, rx, 6, 0.012 * 8 + g_margin_ms, kNoStall), kCm730)) {
    printf("Dynamixel Power on (WRITE 200 24 1) not answered\n");
    return 2;
  }
  const unsigned char led[] = {26, 0x1F, 0x02}; /* MakeColor(255, 128, 0) = 0x021F */
  packet(tx, kCm730, kWrite, led, 3);
  transact(tx, 9, rx, 6, 0.012 * 9 + g_margin_ms, kNoStall);
  usleep(300000);
  int present[21] = {0};
  int joints_read = 0;
  for (int id = 1; id <= 20; ++id) {
    const unsigned char read_position[] = {36, 2};
    packet(tx, id, kRead, read_position, 2);
    const int n = transact(tx, 8, rx, 8, 0.012 * 8 + g_margin_ms, kNoStall);
    joints_read += status_ok(rx, n, id);
    present[id] = status_ok(rx, n, id) ? rx[5] | (rx[6] << 8) : 2048;
  }
  printf("initialize read=%d of 20\n", joints_read);

  /* LinuxMotionTimer::Start, then ball_following's SYNC WRITE from the main thread. */
  pthread_t timer_thread;
  if (start_real_time(&timer_thread, SCHED_RR, 31, timer) != 0) return 3;
  unsigned char params[2 + 20 * 5];
  int n = 0;
  params[n++] = 30; /* Goal Position */
  params[n++] = 4;  /* goal, moving speed */
  for (int id = 1; id <= 20; ++id) {
    const int goal = 2048, distance = abs(present[id] - goal) >> 2;
    const int speed = distance < 8 ? 8 : distance;
    params[n++] = (unsigned char)id;
    params[n++] = goal & 0xFF;
    params[n++] = goal >> 8;
    params[n++] = speed & 0xFF;
    params[n++] = speed >> 8;
  }
  packet(tx, kBroadcast, kSyncWrite, params, n);
  transact(tx, n + 6, rx, 0, 0, kStallSyncWrite);

  pthread_join(timer_thread, NULL);
  int ok = g_ping_ok[0] && g_ping_ok[1] && g_ping_ok[2] && g_bulk_complete > 0;
  printf("pings 200=%s 112=%s 111=%s bulk_reads answered=%d of %d\n", g_ping_ok[0] ? "ok" : "FAIL",
         g_ping_ok[1] ? "ok" : "FAIL", g_ping_ok[2] ? "ok" : "FAIL", g_bulk_complete, g_bulk_sent);
  if (g_doppel != 0) {
    while (atomic_load(&g_resumes) < atomic_load(&g_stalls)) pause_briefly();
    atomic_store(&g_quit, 1);
    sem_post(&g_resume_request);
    pthread_join(resumer_thread, NULL);
    kill(g_doppel, SIGCONT);
    static const char* const kResult[] = {"not-stalled", "after-resume", "while-stopped"};
    printf("stalled writes sync_write=%s ping200=%s ping112=%s ping111=%s\n", kResult[g_stall_result[kStallSyncWrite]],
           kResult[g_stall_result[kStallPing200]], kResult[g_stall_result[kStallPing112]],
           kResult[g_stall_result[kStallPing111]]);
    for (int k = 0; k < kStallPoints; ++k) ok = ok && g_stall_result[k] == kAfterResume;
    if (g_stall_error != NULL) {
      printf("stalling doppel (pid %d) failed: %s\n", (int)g_doppel, g_stall_error);
      return 2;
    }
  }
  return ok ? 0 : 1;
}
