/* Asks a serial port what a driver may ask a USB adapter, written from ioctl_tty(2) and termios(3):
 * prints one "name=value" line per answer for the shim tests to check against Linux's FTDI driver.
 * Usage: serial_probe DEVICE STEP... with the steps
 *   serial      TIOCGSERIAL: baud_base, flags, custom_divisor, close_delay, closing_wait, line
 *   custom      B38400 by tcsetattr, then ASYNC_SPD_CUST with custom_divisor = baud_base / 1000000
 *               by TIOCSSERIAL; prints the line rate (TCGETS2 c_ospeed) after it and after a
 *               second tcsetattr with B38400
 *   modem       TIOCMGET, TIOCMBIC(DTR), TIOCMGET, TIOCMBIS(DTR), TIOCMSET(0), TIOCMGET
 *   rs485       TIOCGRS485 and TIOCSRS485: result and errno
 *   flushes     tcflush TCOFLUSH / TCIOFLUSH / TCIFLUSH results
 *   lowlatency  sets ASYNC_LOW_LATENCY by TIOCSSERIAL
 *   stat        stat/lstat/access of DEVICE: is it a character device, accessible
 * Exit 0 after all steps (an answer that is an error is printed, not fatal), 2 when DEVICE does not open. */
#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include "line_rate.h"

/* tcsetattr with B38400 raw 8N1, as the DARwIn-OP framework sets its line before TIOCSSERIAL. */
static void set_b38400(int fd) {
  struct termios t;
  memset(&t, 0, sizeof(t));
  t.c_cflag = B38400 | CS8 | CLOCAL | CREAD;
  t.c_iflag = IGNPAR;
  printf("tcsetattr=%d\n", tcsetattr(fd, TCSANOW, &t));
}

static void result(const char* name, int r) { printf("%s=%d errno=%d\n", name, r, r < 0 ? errno : 0); }

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  int fd = open(argv[1], O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) {
    printf("open failed: %s\n", strerror(errno));
    return 2;
  }
  for (int i = 2; i < argc; ++i) {
    const char* step = argv[i];
    struct serial_struct s;
    memset(&s, 0, sizeof(s));
    if (strcmp(step, "serial") == 0) {
      int r = ioctl(fd, TIOCGSERIAL, &s);
      result("TIOCGSERIAL", r);
      printf("baud_base=%d\nflags=%d\ncustom_divisor=%d\nclose_delay=%u\nclosing_wait=%u\nline=%d\ntype=%d\n",
             s.baud_base, s.flags, s.custom_divisor, s.close_delay, s.closing_wait, s.line, s.type);
    } else if (strcmp(step, "custom") == 0) {
      set_b38400(fd);
      printf("rate_before=%u\n", line_rate(fd));
      ioctl(fd, TIOCGSERIAL, &s);
      s.flags = (s.flags & ~ASYNC_SPD_MASK) | ASYNC_SPD_CUST;
      s.custom_divisor = s.baud_base / 1000000;
      result("TIOCSSERIAL", ioctl(fd, TIOCSSERIAL, &s));
      printf("rate_after_custom=%u\n", line_rate(fd));
      set_b38400(fd);
      printf("rate_after_b38400_again=%u\n", line_rate(fd));
    } else if (strcmp(step, "modem") == 0) {
      int lines = -1;
      result("TIOCMGET", ioctl(fd, TIOCMGET, &lines));
      printf("lines=%d\n", lines);
      int dtr = TIOCM_DTR;
      result("TIOCMBIC", ioctl(fd, TIOCMBIC, &dtr));
      ioctl(fd, TIOCMGET, &lines);
      printf("lines_after_bic_dtr=%d\n", lines);
      result("TIOCMBIS", ioctl(fd, TIOCMBIS, &dtr));
      ioctl(fd, TIOCMGET, &lines);
      printf("lines_after_bis_dtr=%d\n", lines);
      int none = 0;
      result("TIOCMSET", ioctl(fd, TIOCMSET, &none));
      ioctl(fd, TIOCMGET, &lines);
      printf("lines_after_set_0=%d\n", lines);
    } else if (strcmp(step, "rs485") == 0) {
      unsigned char rs485[32];
      memset(rs485, 0, sizeof(rs485));
      result("TIOCGRS485", ioctl(fd, TIOCGRS485, rs485));
      result("TIOCSRS485", ioctl(fd, TIOCSRS485, rs485));
    } else if (strcmp(step, "flushes") == 0) {
      result("TCOFLUSH", tcflush(fd, TCOFLUSH));
      result("TCIOFLUSH", tcflush(fd, TCIOFLUSH));
      result("TCIFLUSH", tcflush(fd, TCIFLUSH));
    } else if (strcmp(step, "lowlatency") == 0) {
      ioctl(fd, TIOCGSERIAL, &s);
      s.flags |= ASYNC_LOW_LATENCY;
      result("TIOCSSERIAL_low_latency", ioctl(fd, TIOCSSERIAL, &s));
    } else if (strcmp(step, "stat") == 0) {
      struct stat st;
      printf("stat_chr=%d\n", stat(argv[1], &st) == 0 && S_ISCHR(st.st_mode));
      printf("lstat_chr=%d\n", lstat(argv[1], &st) == 0 && S_ISCHR(st.st_mode));
      printf("access=%d\n", access(argv[1], R_OK | W_OK));
    } else {
      printf("unknown step %s\n", step);
    }
  }
  close(fd);
  return 0;
}
