// Custom line rates as DynamixelSDK sets them (TCSETS2 with BOTHER, reference §4.4). This file
// uses the kernel's termios2 and must not include glibc's <termios.h>.
#include <asm/termbits.h>
#include <gtest/gtest.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include "bus/pty_port.h"
#include "pty_test_support.h"

namespace doppel::bus {
namespace {

bool set_custom_rate(int fd, uint32_t bps) {
  struct termios2 tio {};
  if (::ioctl(fd, TCGETS2, &tio) != 0) return false;
  tio.c_cflag &= ~CBAUD;
  tio.c_cflag |= BOTHER;
  tio.c_ispeed = bps;
  tio.c_ospeed = bps;
  return ::ioctl(fd, TCSETS2, &tio) == 0;
}

TEST(PtyPortBaud, ReadsBackBotherRatesUpTo4500000) {
  testing::TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  const testing::ClientFd client(testing::open_client(sut.link_path()));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(set_custom_rate(client, 4'500'000));
  const uint32_t at_4m5 = sut.line_baud_bps();
  ASSERT_TRUE(set_custom_rate(client, 2'250'000));  // MX special code 250
  const uint32_t at_2m25 = sut.line_baud_bps();
  ASSERT_TRUE(set_custom_rate(client, 57'142));  // P1 register 34 exactly: 2 Mbps / 35
  const uint32_t at_57k = sut.line_baud_bps();

  EXPECT_EQ(at_4m5, 4'500'000u);
  EXPECT_EQ(at_2m25, 2'250'000u);
  EXPECT_EQ(at_57k, 57'142u);
}

}  // namespace
}  // namespace doppel::bus
