#pragma once
// The line set-up DynamixelSDK does for any rate (reference §4.4): raw 8N1, VMIN = VTIME = 0, and the
// rate itself through TCSETS2 with BOTHER. Written from the reference with plain ioctls, for the
// reference clients and the bus tests. Uses the kernel's termios2: <termios.h> clashes with it.

#include <asm/termbits.h>
#include <sys/ioctl.h>

#include <cstdint>

namespace doppel::testing {

// Sets the line of `fd` up at `baud_bps`. Returns nullptr, or the name of the ioctl that failed
// ("TCGETS2" or "TCSETS2"; errno says why).
inline const char* set_bother_line(int fd, uint32_t baud_bps) {
  struct termios2 tio {};
  if (::ioctl(fd, TCGETS2, &tio) != 0) return "TCGETS2";
  tio.c_iflag = IGNPAR;
  tio.c_oflag = 0;
  tio.c_lflag = 0;
  tio.c_cflag = CS8 | CLOCAL | CREAD | BOTHER;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  tio.c_ispeed = baud_bps;
  tio.c_ospeed = baud_bps;
  if (::ioctl(fd, TCSETS2, &tio) != 0) return "TCSETS2";
  return nullptr;
}

}  // namespace doppel::testing
