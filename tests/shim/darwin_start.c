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
 * With --starve CPU the timer thread runs on CPU CPU and a SCHED_FIFO 1 thread spins on every
 * other CPU from before the timer starts until CYCLES cycles later: ordinary (SCHED_OTHER) work,
 * the kernel's tty hand-over included, then finds a CPU only while the timer thread sleeps. That
 * is the 2-core machine whose other core is busy, made certain.
 * Usage: darwin_start DEVICE [--cycles N] [--starve CPU]. Prints one line:
 *   "pings 200=ok 112=ok 111=ok bulk_reads answered=N of M"
 * exit 0: the three PINGs were answered and every BULK READ returned all three statuses;
 * 1: not; 2: a set-up step failed (named); 3: --starve asked but SCHED_FIFO/affinity refused. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <pthread.h>
#include <sched.h>
#include <semaphore.h>
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
static atomic_int g_starving = 0;
static int g_starve_cpu = -1;

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

/* One transaction; returns the bytes received (expected = what a complete answer holds). */
static int transact(const unsigned char* tx, int length, unsigned char* rx, int expected, double timeout_ms) {
  while (sem_wait(&g_bus) != 0 && errno == EINTR) {
  }
  int got = 0;
  tcflush(g_fd, TCIFLUSH);
  if (write(g_fd, tx, (size_t)length) == length && expected > 0) {
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

static int ping(int id) {
  unsigned char tx[6], rx[6];
  packet(tx, id, kPing, NULL, 0);
  const int n = transact(tx, 6, rx, 6, 0.012 * 6 + 5.0);
  return status_ok(rx, n, id);
}

static void make_bulk_read(void) {
  static const int ids[3] = {kCm730, kLeftFsr, kRightFsr};
  unsigned char params[1 + 9];
  int n = 0;
  params[n++] = 0x00;
  for (int k = 0; k < 3; ++k) {
    g_ping_ok[k] = ping(ids[k]);
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
  const int got = transact(g_bulk, length, rx, g_bulk_reply_bytes, 0.012 * g_bulk_reply_bytes * 1.5 + 5.0);
  g_bulk_sent++;
  if (g_bulk_devices == 3 && got == g_bulk_reply_bytes && status_ok(rx, 36, kCm730) &&
      status_ok(rx + 36, 16, kLeftFsr) && status_ok(rx + 52, 16, kRightFsr)) {
    g_bulk_complete++;
  }
}

static void* starve(void* arg) {
  (void)arg;
  while (atomic_load(&g_starving)) {
  }
  return NULL;
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
  atomic_store(&g_starving, 0);
  return NULL;
}

static int failed(const char* step) {
  printf("%s failed: %s (errno %d)\n", step, strerror(errno), errno);
  return 2;
}

static int on_cpu(pthread_attr_t* attr, int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_attr_setaffinity_np(attr, sizeof(set), &set);
}

int main(int argc, char** argv) {
  const char* device = argc > 1 ? argv[1] : "/dev/ttyUSB0";
  for (int i = 2; i + 1 < argc; i += 2) {
    if (strcmp(argv[i], "--cycles") == 0) g_cycles = atoi(argv[i + 1]);
    if (strcmp(argv[i], "--starve") == 0) g_starve_cpu = atoi(argv[i + 1]);
  }
  setvbuf(stdout, NULL, _IOLBF, 0);
  sem_init(&g_bus, 0, 1);

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
  if (!status_ok(rx, transact(tx, 8, rx, 6, 0.012 * 8 + 5.0), kCm730)) {
    printf("Dynamixel Power on (WRITE 200 24 1) not answered\n");
    return 2;
  }
  const unsigned char led[] = {26, 0x1F, 0x02}; /* MakeColor(255, 128, 0) = 0x021F */
  packet(tx, kCm730, kWrite, led, 3);
  transact(tx, 9, rx, 6, 0.012 * 9 + 5.0);
  usleep(300000);
  int present[21] = {0};
  for (int id = 1; id <= 20; ++id) {
    const unsigned char read_position[] = {36, 2};
    packet(tx, id, kRead, read_position, 2);
    const int n = transact(tx, 8, rx, 8, 0.012 * 8 + 5.0);
    present[id] = status_ok(rx, n, id) ? rx[5] | (rx[6] << 8) : 2048;
  }

  pthread_t hogs[64];
  int hog_count = 0;
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  pthread_attr_t attr;
  struct sched_param param;
  if (g_starve_cpu >= 0) {
    atomic_store(&g_starving, 1);
    for (int cpu = 0; cpu < cpus && hog_count < 64; ++cpu) {
      if (cpu == g_starve_cpu) continue;
      pthread_attr_init(&attr);
      pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
      pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
      param.sched_priority = 1;
      pthread_attr_setschedparam(&attr, &param);
      if (on_cpu(&attr, cpu) != 0 || pthread_create(&hogs[hog_count], &attr, starve, NULL) != 0) {
        atomic_store(&g_starving, 0);
        printf("--starve: a SCHED_FIFO thread on CPU %d was refused (run as root)\n", cpu);
        return 3;
      }
      hog_count++;
    }
  }

  /* LinuxMotionTimer::Start, then ball_following's SYNC WRITE from the main thread. */
  pthread_attr_init(&attr);
  pthread_attr_setschedpolicy(&attr, SCHED_RR);
  pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
  param.sched_priority = 31;
  pthread_attr_setschedparam(&attr, &param);
  if (g_starve_cpu >= 0 && on_cpu(&attr, g_starve_cpu) != 0) return 3;
  pthread_t timer_thread;
  const int error = pthread_create(&timer_thread, &attr, timer, NULL);
  if (error != 0) {
    atomic_store(&g_starving, 0);
    printf("the SCHED_RR 31 timer thread was refused: %s (run as root)\n", strerror(error));
    return 3;
  }
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
  transact(tx, n + 6, rx, 0, 0);

  pthread_join(timer_thread, NULL);
  for (int h = 0; h < hog_count; ++h) pthread_join(hogs[h], NULL);
  const int ok = g_ping_ok[0] && g_ping_ok[1] && g_ping_ok[2] && g_bulk_complete == g_bulk_sent && g_bulk_sent > 0;
  printf("pings 200=%s 112=%s 111=%s bulk_reads answered=%d of %d\n", g_ping_ok[0] ? "ok" : "FAIL",
         g_ping_ok[1] ? "ok" : "FAIL", g_ping_ok[2] ? "ok" : "FAIL", g_bulk_complete, g_bulk_sent);
  return ok ? 0 : 1;
}
