// A Protocol 1.0 controller written from the Dynamixel e-Manual (Protocol 1.0 packet, READ 0x02,
// WRITE 0x03, SYNC WRITE 0x83; RX-28/RX-64 control table: Torque Enable 24, Goal Position 30,
// Present Position 36) and the man pages, never with Doppel's code: the program lockstep runs.
//
//   lockstep_controller MODE PORT SECONDS
//
// MODE single: one thread, a 1 kHz loop paced by clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC;
//   every cycle a SYNC WRITE of the goal positions of IDs 1..21 (a slow sine) and a READ of one
//   servo's Present Position, waited for with poll().
// MODE timer: a timer thread (timerfd, 1 kHz, blocking read) wakes the main thread through a
//   condition variable; the main thread reads its replies as DynamixelSDK does (non-blocking
//   read() in a loop, timed out on CLOCK_REALTIME).
// MODE sem: a thread paced by nanosleep (1 ms) posts a semaphore the main thread waits on.
// MODE pipe: a thread paced by usleep (1 ms) writes a byte to a pipe the main thread reads (blocking).
// MODE framework: the way the DARwIn-OP framework's Linux port reads and waits (facts from its
//   published source, github darwinop-ens/darwin-op LinuxCM730/CM730; not its code): the port is
//   O_NONBLOCK with VMIN = VTIME = 0 and a status is read by adding read()'s return value to the
//   byte count, unchecked, until the count is reached or gettimeofday says the wait is over; between
//   cycles it waits 1 ms as LinuxCM730::Sleep does, usleep(milliseconds left, passed as
//   microseconds) and gettimeofday in a loop, which ends in usleep(0) calls. On the robot an empty
//   read returns 0 (the kernel's n_tty_read), and even usleep(0) lets time pass.
// MODE busy: spins without any call the shim intercepts (the watchdog must name it).
// MODE overrun: 1000 clock_nanosleep(TIMER_ABSTIME) calls to a time 1 ms before now (the man page:
//   "less than or equal to the current value of the clock ... returns immediately without
//   suspending the calling thread"), then usleep(0) until CLOCK_MONOTONIC has moved 1 ms (at most
//   20000 times), then SECONDS of relative sleep; prints "late_sleeps=N" (how many returned 0 with
//   CLOCK_MONOTONIC unchanged) and "zero_sleeps=N" (the usleep(0) calls; -1 if time never moved).
// Every mode counts reads of the port that returned -1 ("read_errors=N"): termios(3), MIN == 0,
// TIME == 0: "If no data is available, read(2) returns 0".
//
// Prints "cycles=N replies=N timeouts=N end_s=S" when SECONDS of CLOCK_MONOTONIC have passed.
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static int port = -1;
static long replies = 0, timeouts = 0, read_errors = 0;

static double now_s(clockid_t clock) {
  struct timespec ts;
  clock_gettime(clock, &ts);
  return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void send_packet(uint8_t id, uint8_t instruction, const uint8_t* params, int n) {
  uint8_t packet[256];
  packet[0] = 0xFF;
  packet[1] = 0xFF;
  packet[2] = id;
  packet[3] = (uint8_t)(n + 2);
  packet[4] = instruction;
  uint8_t sum = (uint8_t)(id + packet[3] + instruction);
  for (int i = 0; i < n; ++i) {
    packet[5 + i] = params[i];
    sum = (uint8_t)(sum + params[i]);
  }
  packet[5 + n] = (uint8_t)~sum;
  const ssize_t written = write(port, packet, (size_t)(n + 6));
  if (written != n + 6) {
    fprintf(stderr, "write failed: %s\n", strerror(errno));
    exit(1);
  }
}

// Reads a status of `expected` bytes: with poll() (sdk_style = 0) or DynamixelSDK's way, a
// non-blocking read loop that checks CLOCK_REALTIME for its timeout.
static int receive(int expected, int sdk_style) {
  uint8_t buffer[64];
  int got = 0;
  const double deadline_real = now_s(CLOCK_REALTIME) + 0.010;
  const double deadline_mono = now_s(CLOCK_MONOTONIC) + 0.010;
  while (got < expected) {
    if (!sdk_style) {
      const int left_ms = (int)ceil((deadline_mono - now_s(CLOCK_MONOTONIC)) * 1000.0);
      struct pollfd p = {port, POLLIN, 0};
      if (left_ms <= 0 || poll(&p, 1, left_ms) <= 0) break;
    }
    const ssize_t n = read(port, buffer + got, (size_t)(expected - got));
    if (n > 0) got += (int)n;
    if (n < 0) ++read_errors;
    if (sdk_style && got < expected && now_s(CLOCK_REALTIME) > deadline_real) break;
  }
  if (got == expected && buffer[0] == 0xFF && buffer[1] == 0xFF) {
    ++replies;
    return 1;
  }
  ++timeouts;
  return 0;
}

static double wall_ms(void) {
  struct timeval tv;
  gettimeofday(&tv, NULL);
  return (double)tv.tv_sec * 1000.0 + (double)tv.tv_usec / 1000.0;
}

// A READ of Present Position (36, 2 bytes) of servo `id`, received the framework's way.
static void framework_cycle(uint8_t id) {
  const uint8_t read_params[2] = {36, 2};
  send_packet(id, 0x02, read_params, 2);
  uint8_t raw[96];
  uint8_t* buffer = raw + 32;  // room for a count gone negative (each read that says -1)
  int got = 0;
  const int expected = 8;
  const double start = wall_ms();
  while (got < expected && got > -32) {
    const ssize_t n = read(port, buffer + got, (size_t)(expected - got));
    if (n < 0) ++read_errors;
    got += (int)n;
    if (got < expected && wall_ms() - start > 5.0) break;
  }
  if (got == expected && buffer[0] == 0xFF && buffer[1] == 0xFF && buffer[2] == id) {
    ++replies;
  } else {
    ++timeouts;
  }
}

static void framework_sleep(double msec) {
  const double start = wall_ms();
  double now = start;
  do {
    usleep((useconds_t)((start + msec) - now));
    now = wall_ms();
  } while (now - start < msec);
}

static void cycle(long n, double t, int sdk_style) {
  // SYNC WRITE Goal Position (30), 2 bytes, IDs 1..21: 512 +- 40 units at 0.5 Hz.
  uint8_t params[2 + 21 * 3];
  params[0] = 30;
  params[1] = 2;
  const int goal = 512 + (int)lrint(40.0 * sin(2.0 * M_PI * 0.5 * t));
  for (int i = 0; i < 21; ++i) {
    params[2 + 3 * i] = (uint8_t)(i + 1);
    params[3 + 3 * i] = (uint8_t)(goal & 0xFF);
    params[4 + 3 * i] = (uint8_t)(goal >> 8);
  }
  send_packet(0xFE, 0x83, params, (int)sizeof(params));
  // READ Present Position (36), 2 bytes, of one servo a cycle: status FF FF ID 4 ERR P0 P1 CHK.
  const uint8_t read_params[2] = {36, 2};
  send_packet((uint8_t)(1 + n % 21), 0x02, read_params, 2);
  receive(8, sdk_style);
}

static void set_up_port(const char* path) {
  port = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (port < 0) {
    fprintf(stderr, "cannot open %s: %s\n", path, strerror(errno));
    exit(1);
  }
  struct termios tio;
  memset(&tio, 0, sizeof tio);
  tio.c_cflag = CS8 | CLOCAL | CREAD;
  cfsetispeed(&tio, B1000000);
  cfsetospeed(&tio, B1000000);
  tcsetattr(port, TCSANOW, &tio);
  tcflush(port, TCIFLUSH);
  const uint8_t torque[2] = {24, 1};  // WRITE Torque Enable = 1 to every servo (broadcast: no status)
  send_packet(0xFE, 0x03, torque, 2);
}

static pthread_mutex_t mutex = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t tick = PTHREAD_COND_INITIALIZER;
static long ticks = 0;
static volatile int done = 0;

static void* timer_thread(void* argument) {
  (void)argument;
  const int fd = timerfd_create(CLOCK_MONOTONIC, 0);
  struct itimerspec period = {{0, 1000000}, {0, 1000000}};
  timerfd_settime(fd, 0, &period, NULL);
  while (!done) {
    uint64_t expirations = 0;
    if (read(fd, &expirations, sizeof expirations) != sizeof expirations) break;
    pthread_mutex_lock(&mutex);
    ticks += (long)expirations;
    pthread_cond_signal(&tick);
    pthread_mutex_unlock(&mutex);
  }
  close(fd);
  return NULL;
}

static sem_t semaphore;
static int pipe_fds[2];

static void* sem_thread(void* argument) {
  (void)argument;
  const struct timespec period = {0, 1000000};
  while (!done) {
    nanosleep(&period, NULL);
    sem_post(&semaphore);
  }
  return NULL;
}

static void* pipe_thread(void* argument) {
  (void)argument;
  const char byte = 't';
  while (!done) {
    usleep(1000);
    if (write(pipe_fds[1], &byte, 1) != 1) break;
  }
  return NULL;
}

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: %s single|timer|sem|pipe|overrun|framework|busy PORT SECONDS\n", argv[0]);
    return 2;
  }
  const char* mode = argv[1];
  signal(SIGPIPE, SIG_IGN);
  const double seconds = atof(argv[3]);
  set_up_port(argv[2]);
  const double start = now_s(CLOCK_MONOTONIC);
  long cycles = 0;
  if (strcmp(mode, "single") == 0) {
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    while (now_s(CLOCK_MONOTONIC) - start < seconds) {
      cycle(cycles, now_s(CLOCK_MONOTONIC) - start, 0);
      ++cycles;
      next.tv_nsec += 1000000;
      if (next.tv_nsec >= 1000000000) {
        next.tv_nsec -= 1000000000;
        ++next.tv_sec;
      }
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
    }
  } else if (strcmp(mode, "timer") == 0) {
    pthread_t thread;
    pthread_create(&thread, NULL, timer_thread, NULL);
    long seen = 0;
    while (now_s(CLOCK_MONOTONIC) - start < seconds) {
      pthread_mutex_lock(&mutex);
      while (ticks == seen) pthread_cond_wait(&tick, &mutex);
      seen = ticks;
      pthread_mutex_unlock(&mutex);
      cycle(cycles, now_s(CLOCK_MONOTONIC) - start, 1);
      ++cycles;
    }
    done = 1;
    pthread_join(thread, NULL);
  } else if (strcmp(mode, "sem") == 0 || strcmp(mode, "pipe") == 0) {
    const int use_sem = strcmp(mode, "sem") == 0;
    pthread_t thread;
    if (use_sem) {
      sem_init(&semaphore, 0, 0);
    } else if (pipe(pipe_fds) != 0) {
      return 1;
    }
    pthread_create(&thread, NULL, use_sem ? sem_thread : pipe_thread, NULL);
    while (now_s(CLOCK_MONOTONIC) - start < seconds) {
      if (use_sem) {
        sem_wait(&semaphore);
      } else {
        char byte;
        if (read(pipe_fds[0], &byte, 1) != 1) break;
      }
      cycle(cycles, now_s(CLOCK_MONOTONIC) - start, 0);
      ++cycles;
    }
    done = 1;
    if (!use_sem) close(pipe_fds[0]);  // the writer's next write fails (EPIPE ignored below)
    pthread_join(thread, NULL);
  } else if (strcmp(mode, "overrun") == 0) {
    struct timespec before, past, after;
    clock_gettime(CLOCK_MONOTONIC, &before);
    past = before;
    past.tv_sec -= 1;
    past.tv_nsec += 999000000;  // before - 1 ms
    if (past.tv_nsec >= 1000000000) {
      past.tv_nsec -= 1000000000;
      ++past.tv_sec;
    }
    long late_sleeps = 0;
    for (int i = 0; i < 1000; ++i) {
      const int r = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &past, NULL);
      clock_gettime(CLOCK_MONOTONIC, &after);
      if (r == 0 && after.tv_sec == before.tv_sec && after.tv_nsec == before.tv_nsec) ++late_sleeps;
    }
    const double zero_start = now_s(CLOCK_MONOTONIC);
    long zero_sleeps = 0;
    while (now_s(CLOCK_MONOTONIC) - zero_start < 0.001 && zero_sleeps < 20000) {
      usleep(0);
      ++zero_sleeps;
    }
    if (now_s(CLOCK_MONOTONIC) - zero_start < 0.001) zero_sleeps = -1;
    printf("late_sleeps=%ld zero_sleeps=%ld\n", late_sleeps, zero_sleeps);
    const struct timespec rest = {(time_t)seconds, (long)((seconds - (double)(time_t)seconds) * 1e9)};
    nanosleep(&rest, NULL);
  } else if (strcmp(mode, "framework") == 0) {
    while (now_s(CLOCK_MONOTONIC) - start < seconds) {
      framework_cycle((uint8_t)(1 + cycles % 21));
      ++cycles;
      framework_sleep(1.0);
    }
  } else if (strcmp(mode, "busy") == 0) {
    volatile uint64_t spin = 0;
    for (;;) ++spin;  // no call at all: invisible to the shim
  } else {
    fprintf(stderr, "unknown mode %s\n", mode);
    return 2;
  }
  printf("cycles=%ld replies=%ld timeouts=%ld read_errors=%ld end_s=%.6f\n", cycles, replies, timeouts, read_errors,
         now_s(CLOCK_MONOTONIC) - start);
  return 0;
}
