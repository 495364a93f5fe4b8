// The map doppel-run hands its preload library, and the sysfs names of an FTDI latency timer.
#include "shim/port_map.h"

#include <gtest/gtest.h>

#include <string>

#include "base/latency_timer.h"

namespace doppel::shim {
namespace {

TEST(PortMap, ParsesEveryMappingInOrder) {
  PortMap sut;
  ASSERT_TRUE(sut.parse("/dev/ttyUSB0=/run/d/ttyDXL0:/dev/U2D2=/run/d/ttyDXL0:/dev/ttyUSB1=/run/d/ttyDXL1")) << sut.error();
  ASSERT_EQ(sut.size(), 3u);
  EXPECT_STREQ(sut[1].device.data(), "/dev/U2D2");
  EXPECT_STREQ(sut[2].link.data(), "/run/d/ttyDXL1");
  EXPECT_EQ(sut.find_device("/dev/ttyUSB1"), 2);
  EXPECT_EQ(sut.find_device("/dev/ttyUSB"), -1);
  EXPECT_EQ(sut.find_device("/dev/ttyUSB10"), -1);
  EXPECT_STREQ(sut.error(), "");
}

TEST(PortMap, ALinkMayHoldAnEqualsSign) {
  PortMap sut;
  ASSERT_TRUE(sut.parse("/dev/ttyUSB0=/tmp/a=b/ttyDXL0")) << sut.error();
  EXPECT_STREQ(sut[0].link.data(), "/tmp/a=b/ttyDXL0");
}

TEST(PortMap, BadSpecsAreRefusedWithTheEntryNamed) {
  const std::pair<std::string, std::string> cases[] = {
      {"", "DOPPEL_SHIM_PORTS is empty"},
      {"/dev/ttyUSB0", "entry 1 '/dev/ttyUSB0' is not DEVICE=LINK"},
      {"/dev/ttyUSB0=/a:garbage", "entry 2 'garbage' is not DEVICE=LINK"},
      {"ttyUSB0=/a", "the device is not an absolute path"},
      {"/dev/ttyUSB0=a", "the link is not an absolute path"},
      {"/dev/ttyUSB0=", "the link is not an absolute path"},
      {"/dev/ttyUSB0=/a:", "entry 2 '' is not DEVICE=LINK"},
      {"/dev/ttyUSB0=/a:/dev/ttyUSB0=/b", "the device is mapped twice"},
      {"/dev/x=/" + std::string(300, 'a'), "longer than 255 bytes"},
  };
  for (const auto& [spec, message] : cases) {
    PortMap sut;
    EXPECT_FALSE(sut.parse(spec)) << spec;
    EXPECT_NE(std::string(sut.error()).find(message), std::string::npos) << spec << " -> " << sut.error();
    EXPECT_EQ(sut.size(), 0u);
  }
}

TEST(PortMap, MoreThanThirtyTwoMappingsAreRefused) {
  std::string spec;
  for (int i = 0; i < 33; ++i) spec += (i ? ":" : "") + std::string("/dev/ttyUSB") + std::to_string(i) + "=/l";
  PortMap sut;
  EXPECT_FALSE(sut.parse(spec));
  EXPECT_NE(std::string(sut.error()).find("more than 32"), std::string::npos) << sut.error();
}

TEST(LatencyTimerPath, BothSysfsNamesOfTheFtdiAttributeGiveTheTty) {
  EXPECT_EQ(latency_timer_tty("/sys/bus/usb-serial/devices/ttyUSB0/latency_timer"), "ttyUSB0");
  EXPECT_EQ(latency_timer_tty("/sys/class/tty/ttyUSB3/device/latency_timer"), "ttyUSB3");
  EXPECT_EQ(latency_timer_tty("/sys/bus/usb-serial/devices//latency_timer"), "");
  EXPECT_EQ(latency_timer_tty("/sys/bus/usb-serial/devices/a/b/latency_timer"), "");
  EXPECT_EQ(latency_timer_tty("/sys/bus/usb-serial/devices/ttyUSB0/event_char"), "");
  EXPECT_EQ(latency_timer_tty("/dev/ttyUSB0"), "");
}

// ftdi_sio latency_timer_store reads with kstrtou8(buf, 10): digits, optional '+', one trailing
// newline; Doppel keeps the FTDI range 1..255.
TEST(LatencyTimerText, ReadAsTheKernelReadsTheSysfsFile) {
  EXPECT_EQ(parse_latency_timer_ms("16\n"), 16u);
  EXPECT_EQ(parse_latency_timer_ms("1"), 1u);
  EXPECT_EQ(parse_latency_timer_ms("+255\n"), 255u);
  EXPECT_EQ(parse_latency_timer_ms("007"), 7u);
  for (const char* bad : {"", "\n", "0", "256", "-1", " 1", "1 ", "1\n\n", "0x10", "abc", "99999999999"}) {
    EXPECT_FALSE(parse_latency_timer_ms(bad).has_value()) << "'" << bad << "'";
  }
}

}  // namespace
}  // namespace doppel::shim
