// Only asm/termbits.h here: glibc's termios.h must not be included in this file (see line_rate.h).
#include "line_rate.h"

#include <asm/ioctls.h>
#include <asm/termbits.h>

#include <cerrno>

namespace doppel::shim {
namespace {

struct Standard {
  uint32_t bps;
  unsigned code;
};
// The Bxxxx constants of <asm/termbits.h> from B38400 up (below it nothing needs encoding here).
constexpr Standard kStandard[] = {{38400, B38400},     {57600, B57600},     {115200, B115200},   {230400, B230400},
                                  {460800, B460800},   {500000, B500000},   {576000, B576000},   {921600, B921600},
                                  {1000000, B1000000}, {1152000, B1152000}, {1500000, B1500000}, {2000000, B2000000},
                                  {2500000, B2500000}, {3000000, B3000000}, {3500000, B3500000}, {4000000, B4000000}};

}  // namespace

uint32_t line_rate_bps(IoctlFunction ioctl_fn, int fd) noexcept {
  const int saved = errno;
  struct termios2 tio {};
  const int r = ioctl_fn(fd, TCGETS2, &tio);
  errno = saved;
  return r == 0 ? static_cast<uint32_t>(tio.c_ospeed) : 0;
}

int set_line_rate_bps(IoctlFunction ioctl_fn, int fd, uint32_t bps) noexcept {
  struct termios2 tio {};
  if (ioctl_fn(fd, TCGETS2, &tio) != 0) return -1;
  unsigned code = BOTHER;
  for (const Standard& standard : kStandard) {
    if (standard.bps == bps) code = standard.code;
  }
  tio.c_cflag = (tio.c_cflag & ~(CBAUD | (CBAUD << IBSHIFT))) | code;
  tio.c_ispeed = bps;
  tio.c_ospeed = bps;
  return ioctl_fn(fd, TCSETS2, &tio);
}

}  // namespace doppel::shim
