// The FTDI driver's answers (shim/ftdi_serial.h) against drivers/usb/serial/ftdi_sio.c and
// usb-serial.c of Linux 6.x, cited per test.
#include "shim/ftdi_serial.h"

#include <gtest/gtest.h>

namespace doppel::shim {
namespace {

// ftdi_determine_type: Hi-Speed chips (FT232H, the U2D2's) 120 MHz / 2; get_serial_info copies
// flags, baud_base, custom_divisor; serial_get_serial adds line and the tty_port delays.
TEST(FtdiSerial, GetSerialReportsTheHiSpeedBaudBaseAndPortDefaults) {
  const serial_struct sut = ftdi_get_serial(FtdiSettings{}, 3);
  EXPECT_EQ(sut.baud_base, 60000000);
  EXPECT_EQ(sut.flags, 0);
  EXPECT_EQ(sut.custom_divisor, 0);
  EXPECT_EQ(sut.line, 3);
  EXPECT_EQ(sut.close_delay, 50);     // 0.5 s in 10 ms units
  EXPECT_EQ(sut.closing_wait, 3000);  // 30 s in 10 ms units
  EXPECT_EQ(sut.type, 0);
}

// The DARwIn-OP sequence: SPD_CUST | LOW_LATENCY with divisor = baud_base / 1000000.
TEST(FtdiSerial, CustomDivisorTurnsB38400IntoBaudBaseOverDivisor) {
  FtdiSettings sut;
  serial_struct in = ftdi_get_serial(sut, 0);
  in.flags = (in.flags & ~ASYNC_SPD_MASK) | ASYNC_SPD_CUST | ASYNC_LOW_LATENCY;
  in.custom_divisor = in.baud_base / 1000000;
  const SetSerialResult result = ftdi_set_serial(sut, in, false);
  EXPECT_EQ(result.error, 0);
  EXPECT_TRUE(result.speed_changed);
  EXPECT_TRUE(result.latency_changed);
  EXPECT_EQ(ftdi_line_rate_bps(sut, 38400), 1000000u);
  EXPECT_EQ(ftdi_line_rate_bps(sut, 57600), 57600u);  // only 38400 means "custom" (get_ftdi_divisor)
  EXPECT_EQ(ftdi_get_serial(sut, 0).flags, ASYNC_SPD_CUST | ASYNC_LOW_LATENCY);
  EXPECT_EQ(ftdi_get_serial(sut, 0).custom_divisor, 60);
}

TEST(FtdiSerial, TheSameSettingsAgainChangeNothing) {
  FtdiSettings sut;
  serial_struct in = ftdi_get_serial(sut, 0);
  in.flags |= ASYNC_SPD_CUST;
  in.custom_divisor = 60;
  ftdi_set_serial(sut, in, false);
  const SetSerialResult again = ftdi_set_serial(sut, in, false);
  EXPECT_FALSE(again.speed_changed);
  EXPECT_FALSE(again.latency_changed);
}

TEST(FtdiSerial, ADivisorWithoutSpdCustOrZeroLeavesTheRate) {
  FtdiSettings sut;
  sut.custom_divisor = 60;
  EXPECT_EQ(ftdi_line_rate_bps(sut, 38400), 38400u);
  sut.flags = ASYNC_SPD_CUST;
  sut.custom_divisor = 0;
  EXPECT_EQ(ftdi_line_rate_bps(sut, 38400), 38400u);
}

// set_serial_info: without CAP_SYS_ADMIN, flags outside ASYNC_USR_MASK may not change (EPERM);
// serial_set_serial: nor may close_delay or closing_wait. Nothing changes then.
TEST(FtdiSerial, UnprivilegedChangesOutsideTheUserMaskAreRefused) {
  FtdiSettings sut;
  serial_struct in = ftdi_get_serial(sut, 0);
  in.flags |= ASYNC_SKIP_TEST;
  EXPECT_EQ(ftdi_set_serial(sut, in, false).error, EPERM);
  EXPECT_EQ(sut.flags, 0);
  in = ftdi_get_serial(sut, 0);
  in.close_delay = 10;
  EXPECT_EQ(ftdi_set_serial(sut, in, false).error, EPERM);
  EXPECT_EQ(ftdi_set_serial(sut, in, true).error, 0);
  EXPECT_EQ(ftdi_get_serial(sut, 0).close_delay, 10);
}

// update_mctrl: only DTR and RTS are driven, set wins over clear; ftdi_tiocmget reports them with
// the (unwired) inputs as 0. tty_port_open raises DTR and RTS.
TEST(FtdiSerial, ModemLinesAreDtrAndRtsOnly) {
  FtdiSettings sut;
  EXPECT_EQ(ftdi_modem_lines(sut), TIOCM_DTR | TIOCM_RTS);
  ftdi_update_modem_lines(sut, 0, TIOCM_DTR);
  EXPECT_EQ(ftdi_modem_lines(sut), TIOCM_RTS);
  ftdi_update_modem_lines(sut, TIOCM_DTR | TIOCM_CTS | TIOCM_RI, 0);
  EXPECT_EQ(ftdi_modem_lines(sut), TIOCM_DTR | TIOCM_RTS);
  ftdi_update_modem_lines(sut, TIOCM_RTS, TIOCM_RTS | TIOCM_DTR);
  EXPECT_EQ(ftdi_modem_lines(sut), TIOCM_RTS);
}

}  // namespace
}  // namespace doppel::shim
