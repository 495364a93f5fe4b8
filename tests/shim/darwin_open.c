/* The DARwIn-OP framework's port set-up (ROBOTIS, Linux/build/LinuxCM730.cpp, LinuxCM730::OpenPort),
 * rewritten from the man pages (open(2), termios(3), ioctl_tty(2)): open, B38400 raw line,
 * TIOCGSERIAL, ASYNC_SPD_CUST | ASYNC_LOW_LATENCY with custom_divisor = baud_base / 1000000,
 * TIOCSSERIAL, tcflush(TCIFLUSH). Then one Protocol 1.0 PING of ID 1 (shared/reference/dynamixel.md
 * §1.7: FF FF 01 02 01 FB, status FF FF 01 02 00 FC).
 * Usage: darwin_open DEVICE. Prints one line; exit 0 = status received, 2 = a set-up step failed
 * (the line names it and errno), 3 = no or a wrong status. */
#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static int failed(const char* step) {
  printf("%s failed: %s (errno %d)\n", step, strerror(errno), errno);
  return 2;
}

int main(int argc, char** argv) {
  const char* device = argc > 1 ? argv[1] : "/dev/ttyUSB0";
  const double baudrate = 1000000.0;
  int fd = open(device, O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) return failed("open");

  struct termios newtio;
  memset(&newtio, 0, sizeof(newtio));
  newtio.c_cflag = B38400 | CS8 | CLOCAL | CREAD;
  newtio.c_iflag = IGNPAR;
  newtio.c_oflag = 0;
  newtio.c_lflag = 0;
  newtio.c_cc[VTIME] = 0;
  newtio.c_cc[VMIN] = 0;
  tcsetattr(fd, TCSANOW, &newtio);

  struct serial_struct serinfo;
  if (ioctl(fd, TIOCGSERIAL, &serinfo) < 0) return failed("TIOCGSERIAL");
  serinfo.flags &= ~ASYNC_SPD_MASK;
  serinfo.flags |= ASYNC_SPD_CUST;
  serinfo.flags |= ASYNC_LOW_LATENCY;
  serinfo.custom_divisor = (int)(serinfo.baud_base / baudrate);
  if (ioctl(fd, TIOCSSERIAL, &serinfo) < 0) return failed("TIOCSSERIAL");
  tcflush(fd, TCIFLUSH);

  const unsigned char ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  const unsigned char expected[] = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  if (write(fd, ping, sizeof(ping)) != (ssize_t)sizeof(ping)) return failed("write");
  unsigned char reply[sizeof(expected)];
  size_t got = 0;
  struct timespec start, now;
  clock_gettime(CLOCK_MONOTONIC, &start);
  while (got < sizeof(reply)) {
    struct pollfd p = {fd, POLLIN, 0};
    poll(&p, 1, 10);
    ssize_t n = read(fd, reply + got, sizeof(reply) - got);
    if (n > 0) got += (size_t)n;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if ((now.tv_sec - start.tv_sec) * 1000 + (now.tv_nsec - start.tv_nsec) / 1000000 > 500) break;
  }
  if (got != sizeof(expected) || memcmp(reply, expected, sizeof(expected)) != 0) {
    printf("no status from ID 1 (%zu bytes)\n", got);
    return 3;
  }
  printf("status from ID 1\n");
  close(fd);
  return 0;
}
