// The real-time path allocates nothing: after setup, BusServer serving a bus of real servo models
// (reads, writes, REG_WRITE/ACTION, SYNC WRITE, BULK READ, bad checksums, garbage) calls no
// operator new on its thread. Its own executable, because counting replaces the global operator new.
#include <termios.h>

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <vector>

#include "allocation_counter.h"
#include "bus/bus_server.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/device_factory.h"
#include "pty_test_support.h"
#include "reference_client.h"

namespace doppel::bus {
namespace {

using testing::open_client;
using testing::read_bytes;
using testing::TempDir;
using testing::write_all;

// Packets come from the reference client's framing (tests/support), not from Doppel's encoder.
using doppel::testing::p1_instruction;

class CountingSync final : public DeviceSync {
 public:
  explicit CountingSync(std::vector<dynamixel::SimulatedServo*> servos) : servos_(std::move(servos)) {}
  void before_dispatch() noexcept override { ++calls_; }
  void after_dispatch() noexcept override {
    // What the gateway does after every packet: every servo's registers become its command.
    for (dynamixel::SimulatedServo* servo : servos_) checksum_ += servo->command().goal_position_rad;
  }

 private:
  std::vector<dynamixel::SimulatedServo*> servos_;
  uint64_t calls_ = 0;
  double checksum_ = 0.0;
};

TEST(RealtimeAllocations, BusServerServesPacketsWithoutAllocating) {
  TempDir dir;
  PtyPort port(dir.file("ttyDXL0"));
  dynamixel::BusDevices devices;
  std::vector<dynamixel::BuiltDevice> owned;
  std::vector<dynamixel::SimulatedServo*> servos;
  for (uint8_t id : {1, 2, 3}) {
    owned.push_back(dynamixel::make_protocol1_device("MX-28", id, 1000000));
    devices.add(*owned.back().device);
    servos.push_back(std::get<dynamixel::SimulatedServo*>(owned.back().role));
  }
  CountingSync sync(servos);
  BusServerOptions options;
  options.timing_mode = TimingMode::kFast;
  TrafficTap tap(std::size_t{16} << 20);  // recording on: the tap copies into its ring, never allocates
  options.tap = &tap;
  BusServer sut(port, devices, options, &sync);

  testing::ClientFd client(open_client(port.link_path()));
  ASSERT_GE(client, 0);
  termios tio{};
  ASSERT_EQ(tcgetattr(client, &tio), 0);
  cfmakeraw(&tio);
  cfsetspeed(&tio, B1000000);  // the servos listen at 1 Mbps
  ASSERT_EQ(tcsetattr(client, TCSANOW, &tio), 0);
  const std::vector<std::vector<uint8_t>> traffic = {
      p1_instruction(1, 0x01, {}),                                         // PING
      p1_instruction(2, 0x02, {36, 2}),                                    // READ
      p1_instruction(3, 0x03, {30, 0x00, 0x08}),                           // WRITE
      p1_instruction(1, 0x04, {30, 0x10, 0x08}),                           // REG_WRITE
      p1_instruction(0xFE, 0x05, {}),                                      // ACTION
      p1_instruction(0xFE, 0x83, {30, 2, 1, 0x00, 0x08, 2, 0x00, 0x08}),   // SYNC WRITE
      p1_instruction(0xFE, 0x92, {0x00, 2, 1, 36, 2, 2, 36, 2, 3, 36}),    // BULK READ
      {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x24, 0x02, 0x00},            // bad checksum
      {0x00, 0x13, 0xFF, 0x42},                                    // garbage
  };
  // Warm up: the first session's set-up may allocate (it is not per packet).
  ASSERT_TRUE(write_all(client, traffic[0]));
  for (int i = 0; i < 50; ++i) sut.run_once(1'000'000);
  read_bytes(client, 6, std::chrono::milliseconds(100));

  uint64_t served = 0;
  for (int round = 0; round < 200; ++round) {
    for (const auto& bytes : traffic) {
      ASSERT_TRUE(write_all(client, bytes));
      doppel::testing::count_allocations_on_this_thread(true);
      for (int i = 0; i < 4; ++i) sut.run_once(200'000);
      doppel::testing::count_allocations_on_this_thread(false);
      served += testing::read_available(client).size();
    }
  }
  client.close();
  // PING 6 + READ 8 + WRITE 6 + REG_WRITE 6 + BULK READ 3 x 8 + bad-checksum status 6 per round.
  EXPECT_EQ(served, 200u * (6 + 8 + 6 + 6 + 24 + 6));
  EXPECT_GT(sut.diagnostics().packets, 1000u);
  EXPECT_EQ(tap.dropped(), 0u);
  TapEvent event;
  std::vector<uint8_t> payload;
  EXPECT_TRUE(tap.pop(event, payload));
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "operator new called on the bus thread while serving packets";
}

}  // namespace
}  // namespace doppel::bus
