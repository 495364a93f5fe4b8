#pragma once
// Reading the pty line's baud rate through termios2 (TCGETS2). Kept behind plain functions because
// <asm/termbits.h> and glibc's <termios.h> define the same names differently and cannot meet in
// one translation unit. Private to bus/.

#include <cstdint>

namespace doppel::bus::detail {

// The output speed (bit/s) of the terminal behind `fd`, as the driver set it with either a Bxxxx
// constant or BOTHER; on a pty master this is the slave's setting. 0 on error or B0. rt-safe.
uint32_t line_speed_bps(int fd) noexcept;

}  // namespace doppel::bus::detail
