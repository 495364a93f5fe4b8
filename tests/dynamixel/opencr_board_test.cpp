// OpenCR with the OP3 firmware. Golden table: ROBOTIS-GIT/ROBOTIS-Framework
// robotis_device/devices/sensor/OPEN-CR.device; behaviour and defaults: ROBOTIS-GIT/OpenCR
// libraries/OP3/examples/opencr_op3 (dxl_node_op3.*, dxl_hw_op3.cpp); scales: ROBOTIS-OP3
// open_cr_module (GYRO_FACTOR 2000/32800 deg/s, ACCEL_FACTOR 2/32768 g, voltage x 0.1).
#include "dynamixel/opencr_board.h"

#include <gtest/gtest.h>

#include <numbers>
#include <variant>

#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol2_factory.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::le;
using testing::p2::instruction;
using testing::p2::status;
using testing::p2::transact;
using testing::p2::write_params;

TEST(OpenCr, TableIsOpenCrDevice) {
  const P2ModelSpec& spec = p2_model_spec("OPEN-CR");
  struct Row {
    const char* name;
    uint16_t address;
    uint8_t size;
    Access access;
    Area area;
    int32_t min, max;
    bool is_signed;
  };
  constexpr Access R = Access::kRead;
  constexpr Access RW = Access::kReadWrite;
  constexpr Area E = Area::kEeprom;
  constexpr Area M = Area::kRam;
  // ROBOTIS-GIT/ROBOTIS-Framework commit 288e048, robotis_device/devices/sensor/OPEN-CR.device,
  // row by row: addr | item name | length | access | memory | min | max | signed. 18/20/22 are the
  // firmware's offsets (ROBOTIS-GIT/OpenCR dxl_node_op3.h, EEPROM), not in the .device file.
  const Row rows[] = {
      {"model_number", 0, 2, R, E, 0, 65535, false},         {"version_of_firmware", 2, 1, R, E, 0, 254, false},
      {"ID", 3, 1, RW, E, 0, 252, false},                    {"baudrate", 4, 1, RW, E, 0, 252, false},
      {"return_delay_time", 5, 1, RW, E, 0, 254, false},     {"status_return_level", 16, 1, RW, E, 0, 2, false},
      {"roll_offset", 18, 2, RW, E, -32768, 32767, true},    {"pitch_offset", 20, 2, RW, E, -32768, 32767, true},
      {"yaw_offset", 22, 2, RW, E, -32768, 32767, true},     {"dynamixel_power", 24, 1, RW, M, 0, 1, false},
      {"LED", 25, 1, RW, M, 0, 7, false},                    {"LED_RGB", 26, 2, RW, M, 0, 32767, false},
      {"buzzer", 28, 2, RW, M, 0, 65535, false},             {"button", 30, 1, R, M, 0, 15, false},
      {"present_voltage", 31, 1, R, M, 50, 250, false},      {"gyro_x", 32, 2, R, M, -32800, 32800, true},
      {"gyro_y", 34, 2, R, M, -32800, 32800, true},          {"gyro_z", 36, 2, R, M, -32800, 32800, true},
      {"acc_x", 38, 2, R, M, -32768, 32768, true},           {"acc_y", 40, 2, R, M, -32768, 32768, true},
      {"acc_z", 42, 2, R, M, -32768, 32768, true},           {"roll", 44, 2, R, M, 0, 4096, false},
      {"pitch", 46, 2, R, M, 0, 4096, false},                {"yaw", 48, 2, R, M, 0, 4096, false},
      {"imu_control", 50, 1, RW, M, 0, 255, false}};
  ASSERT_EQ(spec.registers.size(), std::size(rows));
  for (std::size_t i = 0; i < std::size(rows); ++i) {
    const P2RegisterSpec& r = spec.registers[i];
    EXPECT_EQ(r.name, rows[i].name) << "row " << i;
    EXPECT_EQ(r.address, rows[i].address) << r.name;
    EXPECT_EQ(r.size, rows[i].size) << r.name;
    EXPECT_EQ(r.access, rows[i].access) << r.name;
    EXPECT_EQ(r.area, rows[i].area) << r.name;
    EXPECT_EQ(r.min_raw, rows[i].min) << r.name;
    EXPECT_EQ(r.max_raw, rows[i].max) << r.name;
    EXPECT_EQ(r.is_signed, rows[i].is_signed) << r.name;
  }
  EXPECT_EQ(spec.table_bytes, 51u);  // the last item, imu_control, is the byte at 50
  EXPECT_EQ(spec.model_number, 0x7400);  // DXL_NODE_OP3_MODLE_NUMBER
  EXPECT_EQ(spec.default_id, 200);
  EXPECT_EQ(p2_baud_bps(spec.default_baud_raw), 2'000'000u);  // OP3.robot: 2 000 000 baud
}

TEST(OpenCr, PingAndPowerUpTable) {
  OpenCr sut(200, 4);
  EXPECT_EQ(transact(sut, instruction(200, instruction::kPing)), status(200, 0, {0x00, 0x74, 0x02}));
  Bytes expected = {0x00, 0x74, 0x02, 200, 4, 0};
  EXPECT_EQ(transact(sut, instruction(200, instruction::kRead, {0, 0, 6, 0})), status(200, 0, expected));
  // LED RGB 0x001F after dxl_node_op3_init, Dynamixel Power 0.
  EXPECT_EQ(transact(sut, instruction(200, instruction::kRead, {24, 0, 4, 0})), status(200, 0, {0, 0, 0x1F, 0x00}));
}

TEST(OpenCr, TheOp3BulkReadOfButtonToYaw) {
  OpenCr sut(200, 4);
  ImuFeedback f;
  const double deg = std::numbers::pi / 180.0;
  f.w_WS_S_rad_s = {0.0, -100.0 * deg, 10.0 * deg};  // 16.4 counts per deg/s
  f.a_WS_S_m_s2 = {0.0, 0.0, 9.80665};                // 16384 counts per g
  f.roll_rad = 12.34 * deg;                           // 0.1 deg, truncated
  f.yaw_rad = -90.0 * deg;
  sut.apply(f);
  sut.apply(PowerFeedback{12.0, 0.0, 0});  // (12.0 + 0.5) x 10 = 125
  sut.apply(ButtonInput{0x05});            // mode + user
  Bytes data = {0x05, 125};
  for (int16_t v : {int16_t{0}, int16_t{-1640}, int16_t{164}, int16_t{0}, int16_t{0}, int16_t{16384}, int16_t{123},
                    int16_t{0}, int16_t{-900}}) {
    const Bytes b = le(v, 2);
    data.insert(data.end(), b.begin(), b.end());
  }
  // robotis_controller bulk-reads the listed items as one block, button (30) to yaw (48 + 2).
  BusDevices bus;
  bus.add(sut);
  const InstructionPacket p = testing::p2::parse(instruction(0xFE, instruction::kBulkRead, {200, 30, 0, 20, 0}));
  const auto out = bus.dispatch(p, 2'000'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(Bytes(out[0].packet->bytes.begin(), out[0].packet->bytes.begin() + out[0].packet->size),
            status(200, 0, data));
}

TEST(OpenCr, WriteIsAcknowledgedFirstAndSkipsReadOnlyBytes) {
  OpenCr sut(200, 4);
  // LED, LED RGB, buzzer, then the read-only button and voltage: acknowledged, only 25..29 change.
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, {25, 0, 7, 0xE0, 0x03, 0xB8, 0x01, 9, 9})),
            status(200, 0));
  EXPECT_EQ(sut.table()[opencr::kLed], 7);
  EXPECT_EQ(sut.table()[opencr::kLedRgb], 0xE0);
  EXPECT_EQ(sut.table()[opencr::kBuzzer + 1], 0x01);
  EXPECT_EQ(sut.table()[opencr::kButton], 0);
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, write_params(24, 1, 1))), status(200, 0));
  EXPECT_TRUE(sut.dxl_power_on());
  // Beyond the 51-byte table: Data Length error (5).
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, write_params(51, 1, 1))), status(200, 5));
  EXPECT_EQ(transact(sut, instruction(200, instruction::kRead, {60, 0, 1, 0})), status(200, 5));
  // No Status Return Level: level 0 still answers; REBOOT has no handler.
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, write_params(16, 0, 1))), status(200, 0));
  EXPECT_EQ(transact(sut, instruction(200, instruction::kRead, {16, 0, 1, 0})), status(200, 0, {0}));
  EXPECT_EQ(transact(sut, instruction(200, instruction::kReboot)), Bytes{});
}

TEST(OpenCr, NewIdTakesEffectAtPowerUp) {
  OpenCr sut(200, 4);
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, write_params(3, 201, 1))), status(200, 0));
  EXPECT_EQ(sut.table()[opencr::kId], 201);
  EXPECT_EQ(sut.id(), 200);
  EXPECT_EQ(transact(sut, instruction(201, instruction::kPing)), Bytes{});
}

TEST(OpenCr, ImuControlTakesTheCurrentAngleAsOffset) {
  OpenCr sut(200, 4);
  ImuFeedback f;
  f.pitch_rad = 5.0 * std::numbers::pi / 180.0;
  sut.apply(f);
  EXPECT_EQ(static_cast<int16_t>(sut.table()[opencr::kPitch] | (sut.table()[opencr::kPitch + 1] << 8)), 50);
  EXPECT_EQ(transact(sut, instruction(200, instruction::kWrite, write_params(50, 0x0A, 1))), status(200, 0));
  sut.apply(f);
  EXPECT_EQ(sut.table()[opencr::kImuControl], 0);  // bits clear when done
  EXPECT_EQ(sut.table()[opencr::kPitch], 0);
  EXPECT_EQ(sut.table()[opencr::kPitchOffset], 50);
}

TEST(OpenCr, FactoryGivesAController) {
  BuiltDevice d = make_protocol2_device("OPEN-CR", 200, 2'000'000);
  EXPECT_EQ(std::get<SimulatedController*>(d.role), dynamic_cast<OpenCr*>(d.device.get()));
  EXPECT_EQ(d.device->return_delay_us(), 0u);
}

}  // namespace
}  // namespace doppel::dynamixel
