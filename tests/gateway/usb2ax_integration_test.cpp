// End-to-end: a robot file whose bus sits behind a USB2AX (adapter: "usb2ax"), the real doppel
// executable on a real pty, and a client written from shared/reference/dynamixel.md. The adapter's
// answers are built from the Protocol 1.0 framing (reference §1.1) and the firmware's own status
// layout (Xevel/usb2ax, firmware/lufa_usb2ax/AX.c: axStatusPacket, sync_read).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

constexpr uint8_t kPing = 0x01, kRead = 0x02, kSyncReadUsb2ax = 0x84;
constexpr uint8_t kAdapterId = 0xFD;

std::string write_robot(const std::string& adapter_line) {
  const std::string dir = ::testing::TempDir() + "usb2ax-" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/usb2ax.textproto";
  std::ofstream(path) << "name: \"usb2ax\"\nbus {\n baud_bps: 1000000\n protocol: PROTOCOL_1\n supply_voltage_v: 12\n"
                      << adapter_line
                      << " device { id: 1 model: \"AX-12A\" }\n device { id: 2 model: \"AX-12A\" }\n}\n";
  return path;
}

TEST(Usb2axBus, AdapterAnswersPingOfId253) {
  DoppelProcess doppel({"--robot", write_robot(" adapter: \"usb2ax\"\n"), "--timing", "wire"});
  SerialClient client(doppel.link(), 1000000);
  // PING 253: FF FF FD 02 01 FF; the adapter's status FF FF FD 02 00 00 (CK = ~(FD + 02 + 00)).
  EXPECT_EQ(client.transact({0xFF, 0xFF, 0xFD, 0x02, 0x01, 0xFF}, 6), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x00, 0x00}));
  // Servos behind it still answer their own PINGs.
  EXPECT_EQ(client.transact(p1_instruction(2, kPing), 6), p1_instruction(2, 0x00));
}

TEST(Usb2axBus, WithoutTheAdapterNobodyAnswers253) {
  DoppelProcess doppel({"--robot", write_robot(""), "--timing", "fast"});
  SerialClient client(doppel.link(), 1000000);
  EXPECT_TRUE(client.transact(p1_instruction(kAdapterId, kPing), 6, 100).empty());
}

TEST(Usb2axBus, SyncReadGathersEveryServoIntoOneStatusAtWireSpeed) {
  DoppelProcess doppel({"--robot", write_robot(" adapter: \"usb2ax\"\n"), "--timing", "wire"});
  SerialClient client(doppel.link(), 1000000);
  // Each servo's Present Position (36, 2 bytes) read on its own, through the adapter.
  Bytes expected_params;
  for (uint8_t id : {1, 2}) {
    const Bytes reply = client.transact(p1_instruction(id, kRead, {36, 2}), 8);
    ASSERT_EQ(reply.size(), 8u) << int(id);
    expected_params.insert(expected_params.end(), reply.begin() + 5, reply.begin() + 7);
  }
  // SYNC READ 0x84 of both, and of a missing ID 7 (the firmware fills its bytes with FF).
  expected_params.insert(expected_params.end(), {0xFF, 0xFF});
  const Bytes expected = p1_instruction(kAdapterId, 0x00, expected_params);  // FF FF FD LEN 00 data CK
  const auto start = std::chrono::steady_clock::now();
  const Bytes reply = client.transact(p1_instruction(0xFE, kSyncReadUsb2ax, {36, 2, 1, 2, 7}), expected.size(), 500);
  const auto elapsed_us =
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(reply, expected);
  // The adapter reads the servos one after the other: per servo an 8-byte READ and an 8-byte
  // answer at 1 Mbps (80 µs each) after the AX-12A's Return Delay Time (250 x 2 µs), and for ID 7
  // the READ plus its 1 ms answer timeout (USART_TIMEOUT 50 ticks of 20 µs).
  EXPECT_GE(elapsed_us, 2 * (80 + 500 + 80) + 80 + 1000);
}

}  // namespace
}  // namespace doppel::testing
