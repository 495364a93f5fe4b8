// Only asm/termbits.h here: glibc's termios.h must not be included in this file (see line_speed.h).
#include "line_speed.h"

#include <asm/termbits.h>
#include <sys/ioctl.h>

#include "posix_call.h"

namespace doppel::bus::detail {

uint32_t line_speed_bps(int fd) noexcept {
  struct termios2 tio {};
  const SysResult r = posix_call([&] { return ::ioctl(fd, TCGETS2, &tio); });
  if (!r.ok()) return 0;
  // The kernel fills c_ospeed for Bxxxx constants too (tty_termios_encode_baud_rate), so one field
  // covers both ways of setting the rate.
  return static_cast<uint32_t>(tio.c_ospeed);
}

}  // namespace doppel::bus::detail
