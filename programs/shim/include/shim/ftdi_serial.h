#pragma once
// What Linux's FTDI driver (drivers/usb/serial/ftdi_sio.c with usb-serial.c and tty_io.c, Linux
// 6.x) answers to the serial ioctls a pty refuses, as pure functions over one port's settings, so
// the preload library (shim.cpp) stays a thin layer and the answers are testable without it.
//
// - TIOCGSERIAL (tty_tiocgserial zeroes the struct, serial_get_serial fills line, close_delay,
//   closing_wait, ftdi get_serial_info fills flags, baud_base, custom_divisor; type stays 0).
// - TIOCSSERIAL (serial_set_serial: without CAP_SYS_ADMIN a changed close_delay/closing_wait is
//   EPERM; ftdi set_serial_info: a change of flags outside ASYNC_USR_MASK is EPERM, flags are
//   kept & ASYNC_FLAGS, the latency timer is rewritten (1 ms with ASYNC_LOW_LATENCY), and a change
//   of the SPD flags or the custom divisor recomputes the line rate (change_speed)).
// - The rate itself (get_ftdi_divisor): a termios speed of 38400 with ASYNC_SPD_CUST and a
//   non-zero custom_divisor means baud_base / custom_divisor, which tty_encode_baud_rate then
//   writes back into the termios.
// - Modem lines (ftdi_tiocmget/update_mctrl): only DTR and RTS are outputs; the inputs CTS, DSR,
//   RI and CD come from the chip's modem status (the U2D2 wires none of them: read as 0).
// - RS-485 (TIOCGRS485/TIOCSRS485): ftdi_ioctl knows only TIOCSERGETLSR, so they end in ENOTTY.
//
// baud_base: ftdi_determine_type gives 48 MHz / 2 = 24 000 000 for the FT232R (bcdDevice 0x600,
// the CM-730 and USB2Dynamixel) and 120 MHz / 2 = 60 000 000 for the Hi-Speed FT232H (0x900).
// The U2D2 reaches 6 Mbps (ROBOTIS e-manual, U2D2 "Baudrate Maximum 6Mbps"), beyond the FT232R's
// 3 Mbaud, so it is an H-series chip: Doppel reports kU2d2BaudBase. A program computes its divisor
// from the reported baud_base, so 1 Mbps is divisor 60 here and 24 on a CM-730; both give 1 Mbps.

#include <linux/serial.h>
#include <sys/ioctl.h>

#include <cerrno>
#include <cstdint>

namespace doppel::shim {

inline constexpr int kU2d2BaudBase = 120'000'000 / 2;  // ftdi_sio.c, Hi-Speed chips (FT232H)
inline constexpr int kFt232rBaudBase = 48'000'000 / 2;  // ftdi_sio.c, FT232R (for reference)
inline constexpr int kCloseDelay = 50;      // tty_port_init: close_delay 0.5 s, reported in 10 ms units
inline constexpr int kClosingWait = 3000;   // tty_port_init: closing_wait 30 s, reported in 10 ms units

// One port's settings, as ftdi_private and tty_port keep them.
struct FtdiSettings {
  int flags = 0;            // ASYNC_* flags (ASYNC_SPD_CUST, ASYNC_LOW_LATENCY, ...)
  int custom_divisor = 0;   // divisor of baud_base for ASYNC_SPD_CUST
  int close_delay = kCloseDelay;
  int closing_wait = kClosingWait;
  unsigned dtr_rts = TIOCM_DTR | TIOCM_RTS;  // modem outputs: raised when the port opens
};

// TIOCGSERIAL of the tty with minor `line` (ttyUSB<line>).
inline serial_struct ftdi_get_serial(const FtdiSettings& settings, int line) noexcept {
  serial_struct out{};
  out.line = line;
  out.close_delay = static_cast<unsigned short>(settings.close_delay);
  out.closing_wait = static_cast<unsigned short>(settings.closing_wait);
  out.flags = settings.flags;
  out.baud_base = kU2d2BaudBase;
  out.custom_divisor = settings.custom_divisor;
  return out;
}

struct SetSerialResult {
  int error = 0;                // errno (EPERM) or 0
  bool speed_changed = false;   // the SPD flags or the custom divisor changed: recompute the rate
  bool latency_changed = false; // ASYNC_LOW_LATENCY changed: the latency timer is now latency_ms()
};

// TIOCSSERIAL; `admin` = the caller has CAP_SYS_ADMIN. Changes `settings` only on success.
inline SetSerialResult ftdi_set_serial(FtdiSettings& settings, const serial_struct& in, bool admin) noexcept {
  SetSerialResult result;
  if (!admin && (in.close_delay != settings.close_delay || in.closing_wait != settings.closing_wait ||
                 ((in.flags ^ settings.flags) & ~ASYNC_USR_MASK) != 0)) {
    result.error = EPERM;
    return result;
  }
  const int old_flags = settings.flags;
  const int old_divisor = settings.custom_divisor;
  settings.flags = static_cast<int>(static_cast<unsigned>(in.flags) & ASYNC_FLAGS);
  settings.custom_divisor = in.custom_divisor;
  settings.close_delay = in.close_delay;
  settings.closing_wait = in.closing_wait;
  result.latency_changed = ((settings.flags ^ old_flags) & ASYNC_LOW_LATENCY) != 0;
  result.speed_changed = ((settings.flags ^ old_flags) & ASYNC_SPD_MASK) != 0 ||
                         ((settings.flags & ASYNC_SPD_MASK) == ASYNC_SPD_CUST && settings.custom_divisor != old_divisor);
  return result;
}

// The line rate (bit/s) the chip runs at when the termios speed is `termios_bps`.
inline uint32_t ftdi_line_rate_bps(const FtdiSettings& settings, uint32_t termios_bps) noexcept {
  if (termios_bps == 38400 && (settings.flags & ASYNC_SPD_MASK) == ASYNC_SPD_CUST && settings.custom_divisor > 0) {
    return static_cast<uint32_t>(kU2d2BaudBase / settings.custom_divisor);
  }
  return termios_bps;
}

// The modem lines TIOCMGET reports: the outputs as last set, no inputs.
inline int ftdi_modem_lines(const FtdiSettings& settings) noexcept { return static_cast<int>(settings.dtr_rts); }

// TIOCMSET (set = value, clear = ~value), TIOCMBIS (set) or TIOCMBIC (clear): only DTR and RTS
// change; set wins over clear (update_mctrl).
inline void ftdi_update_modem_lines(FtdiSettings& settings, unsigned set, unsigned clear) noexcept {
  constexpr unsigned kOutputs = TIOCM_DTR | TIOCM_RTS;
  clear &= ~set;
  settings.dtr_rts = ((settings.dtr_rts & ~(clear & kOutputs)) | (set & kOutputs));
}

}  // namespace doppel::shim
