#pragma once
// The pty line's rate through termios2 (TCGETS2/TCSETS2), which can express any rate (BOTHER).
// Kept apart because <asm/termbits.h> and glibc's <termios.h> cannot meet in one translation unit.
// The ioctl used is passed in: the preload library must call libc's, never its own.

#include <cstdint>

namespace doppel::shim {

using IoctlFunction = int (*)(int, unsigned long, ...);

// The output speed (bit/s) of the terminal `fd`, 0 on error. errno preserved.
uint32_t line_rate_bps(IoctlFunction ioctl_fn, int fd) noexcept;
// Sets input and output speed of `fd` to `bps` (a Bxxxx constant when there is one, as the kernel's
// tty_encode_baud_rate does, else BOTHER), keeping every other setting. 0 or -1 with errno.
int set_line_rate_bps(IoctlFunction ioctl_fn, int fd, uint32_t bps) noexcept;

}  // namespace doppel::shim
