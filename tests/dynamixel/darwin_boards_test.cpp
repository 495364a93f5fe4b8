// DARwIn-OP CM-730 and FSR boards. Golden tables: darwinop-ens/darwin-op Framework/include/CM730.h
// and FSR.h (addresses), e-Manual platform/op/references "CM-730" and "FSR" (access, initial
// values, scales). Golden packets: the framework's own (Framework/src/CM730.cpp).
#include "dynamixel/darwin_boards.h"

#include <gtest/gtest.h>

#include <numbers>
#include <variant>

#include "dynamixel/bus_devices.h"
#include "dynamixel/device_factory.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::make_packet;
using testing::transact;

// A Protocol 1.0 status as reference §1.1 frames it: FF FF ID LEN ERR PARAMS ~sum.
Bytes p1_status(uint8_t id, uint8_t error, const Bytes& params = {}) {
  Bytes b = {0xFF, 0xFF, id, static_cast<uint8_t>(params.size() + 2), error};
  for (uint8_t v : params) b.push_back(v);
  unsigned sum = 0;
  for (std::size_t i = 2; i < b.size(); ++i) sum += b[i];
  b.push_back(static_cast<uint8_t>(~sum));
  return b;
}

struct Golden {
  uint8_t address;
  uint8_t size;
  Access access;
  int32_t initial;
};

void expect_table(const ModelSpec& spec, std::initializer_list<Golden> golden) {
  ASSERT_EQ(spec.registers.size(), golden.size());
  std::size_t i = 0;
  for (const Golden& g : golden) {
    const RegisterSpec& r = spec.registers[i++];
    EXPECT_EQ(r.address, g.address) << r.name;
    EXPECT_EQ(r.size, g.size) << r.name;
    EXPECT_EQ(r.access, g.access) << r.name;
    EXPECT_EQ(r.default_raw, g.initial) << r.name;
  }
}

constexpr Access R = Access::kRead;
constexpr Access RW = Access::kReadWrite;

TEST(Cm730, TableIsTheFrameworksAndTheManuals) {
  const ModelSpec& spec = model_spec("CM-730");
  EXPECT_EQ(spec.table_bytes, 81);  // CM730::MAXNUM_ADDRESS
  EXPECT_TRUE(spec.bulk_read);
  // P_MODEL_NUMBER_L .. P_ADC15_L; initial values of the e-Manual (RAM sensors: Doppel's at rest).
  expect_table(spec, {{0, 2, R, 0x7300}, {2, 1, R, 0x13},   {3, 1, RW, 200},  {4, 1, RW, 1},    {5, 1, RW, 0},
                      {16, 1, RW, 2},    {24, 1, RW, 0},    {25, 1, RW, 0},   {26, 2, RW, 0},   {28, 2, RW, 0},
                      {30, 1, R, 0},     {38, 2, R, 512},   {40, 2, R, 512},  {42, 2, R, 512},  {44, 2, R, 512},
                      {46, 2, R, 512},   {48, 2, R, 512},   {50, 1, R, 0},    {51, 2, R, 0},    {53, 2, R, 0},
                      {55, 2, R, 0},     {57, 2, R, 0},     {59, 2, R, 0},    {61, 2, R, 0},    {63, 2, R, 0},
                      {65, 2, R, 0},     {67, 2, R, 0},     {69, 2, R, 0},    {71, 2, R, 0},    {73, 2, R, 0},
                      {75, 2, R, 0},     {77, 2, R, 0},     {79, 2, R, 0}});
}

TEST(Cm730, PingAndIdentityRead) {
  Cm730 sut(200, 1, 0);
  EXPECT_EQ(sut.return_delay_us(), 0u);
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kPing)), p1_status(200, 0));
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kRead, {0, 6})),
            p1_status(200, 0, {0x00, 0x73, 0x13, 0xC8, 0x01, 0x00}));
}

TEST(Cm730, ConnectPowersTheServosAndLightsTheHead) {
  Cm730 sut(200, 1, 0);
  EXPECT_FALSE(sut.dxl_power_on());  // e-Manual: initial 0
  // DXLPowerOn(): WriteByte(200, P_DXL_POWER, 1), then WriteWord(200, P_LED_HEAD_L, MakeColor(255, 128, 0)).
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0xC8, 0x04, 0x03, 0x18, 0x01, 0x17}), p1_status(200, 0));
  EXPECT_TRUE(sut.dxl_power_on());
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kWrite, {26, 0x1F, 0x02})), p1_status(200, 0));
  EXPECT_EQ(sut.register_raw(cm730::kLedHead), 0x021F);
  // Disconnect(): the literal packet of CM730.cpp turns the head LED green (0x03E0).
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0xC8, 0x05, 0x03, 0x1A, 0xE0, 0x03, 0x32}), p1_status(200, 0));
  EXPECT_EQ(sut.register_raw(cm730::kLedHead), 0x03E0);
  // Only 0 and 1 mean something; sensors are read-only.
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kWrite, {24, 2})), p1_status(200, p1_error::kRange));
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kWrite, {38, 0, 2})), p1_status(200, p1_error::kRange));
}

TEST(Cm730, GyroAccelerometerAndVoltageScales) {
  Cm730 sut(200, 1, 0);
  ImuFeedback f;
  const double deg = std::numbers::pi / 180.0;
  // S = the accelerometer's axes (x right, y forward, z up); the gyro's X points back, Y right
  // (Webots' DARwIn-OP model, docs/devices.md): Gyro X = -w.y, Gyro Y = w.x.
  f.w_WS_S_rad_s = {-800.0 * deg, -320.0 * deg, 1600.0 * deg};  // 512 + rate x 512 / 1600
  f.a_WS_S_m_s2 = {0.0, -2.0 * 9.80665, 9.80665};              // 512 + a x 128 per g
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(cm730::kGyroX), 614);   // 512 + 320 x 512 / 1600 = 512 + 102.4
  EXPECT_EQ(sut.register_raw(cm730::kGyroY), 256);   // 512 - 256
  EXPECT_EQ(sut.register_raw(cm730::kGyroZ), 1023);  // 1024 saturates
  EXPECT_EQ(sut.register_raw(cm730::kAccelX), 512);
  EXPECT_EQ(sut.register_raw(cm730::kAccelY), 256);
  EXPECT_EQ(sut.register_raw(cm730::kAccelZ), 640);
  sut.apply(PowerFeedback{12.0, 1.0, 0});
  EXPECT_EQ(sut.register_raw(cm730::kVoltage), 120);  // e-Manual: 10 V reads 100
  sut.apply(ButtonInput{0xFF});
  EXPECT_EQ(sut.register_raw(cm730::kButton), 3);  // MODE and START only
}

TEST(Cm730, AccelerometerBytesAreNotTheServosRegisteredAndLock) {
  Cm730 sut(200, 1, 0);
  ImuFeedback f;
  f.a_WS_S_m_s2 = {0.0, 3.0 * 9.80665, 9.80665};  // ACC Y = 896 = 0x0380: byte 47 = 3
  sut.apply(f);
  EXPECT_FALSE(sut.locked());
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kWrite, {5, 10})), p1_status(200, 0));
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kRegWrite, {25, 1})), p1_status(200, 0));
  EXPECT_EQ(sut.register_raw(cm730::kAccelX), 512);  // REG WRITE does not touch byte 44
  EXPECT_EQ(transact(sut, make_packet(200, instruction::kAction)), p1_status(200, 0));
  EXPECT_EQ(sut.register_raw(cm730::kLedPanel), 1);
}

TEST(DarwinFsr, TableIsTheFrameworksAndTheManuals) {
  const ModelSpec& spec = model_spec("DARWIN-FSR");
  EXPECT_EQ(spec.table_bytes, 48);  // FSR::MAXNUM_ADDRESS
  EXPECT_EQ(spec.model_number, 0x0154);
  expect_table(spec, {{0, 2, R, 0x0154}, {2, 1, R, 0x11}, {3, 1, RW, 100}, {4, 1, RW, 34}, {5, 1, RW, 250},
                      {16, 1, RW, 2},    {19, 1, RW, 0},  {25, 1, RW, 0},  {26, 2, R, 0},  {28, 2, R, 0},
                      {30, 2, R, 0},     {32, 2, R, 0},   {34, 1, R, 255}, {35, 1, R, 255}, {42, 1, R, 0},
                      {44, 1, R, 0},     {47, 1, RW, 0}});
  EXPECT_EQ(darwin_fsr::kRightFootId, 111);
  EXPECT_EQ(darwin_fsr::kLeftFootId, 112);
}

TEST(DarwinFsr, ForcesInMillinewtonAndCentreOfPressure) {
  DarwinFsr sut(112, 1, 0);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrX), 255);  // no load
  FootFeedback f;
  f.force_n = {9.8, 0.0, 0.0, 0.0};  // e-Manual: 9.8 N reads 9800
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsr1), 9800);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrX), 0);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrY), 254);
  f.force_n = {5.0, 5.0, 5.0, 5.0};
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrX), 127);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrY), 127);
  f.force_n = {0.4, 0.4, 0.4, 70.0};  // below 0.493 N reads 0; 70 N saturates at 65535
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsr1), 0);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsr4), 65535);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrX), 254);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrY), 0);
  f.force_n = {0.4, 0.0, 0.0, 0.0};
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrX), 255);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kFsrY), 255);
}

TEST(DarwinFsr, PowerCycleClearsRamButKeepsIdAndReadsTheSupplyAgain) {
  DarwinFsr sut(111, 1, 0);
  sut.set_supply_voltage(12.0);
  ASSERT_EQ(sut.write_item(darwin_fsr::kLed, 1), "");

  sut.power_cycle();

  EXPECT_EQ(sut.register_raw(darwin_fsr::kLed), 0);
  EXPECT_EQ(sut.id(), 111);
  EXPECT_EQ(sut.register_raw(darwin_fsr::kPresentVoltage), 120);
}

TEST(DarwinBoards, TheFrameworksBulkReadOfCm730AndFsrs) {
  Cm730 cm(200, 1, 0);
  DarwinFsr left(112, 1, 0);
  DarwinFsr right(111, 1, 0);
  BusDevices bus;
  bus.add(cm);
  bus.add(left);
  bus.add(right);
  FootFeedback f;
  f.force_n = {1.0, 2.0, 3.0, 4.0};
  left.apply(f);
  // MakeBulkReadPacket(): {30, 200, P_DXL_POWER}, {10, 112, P_FSR1_L}, {10, 111, P_FSR1_L}.
  InstructionPacket p = make_packet(0xFE, instruction::kBulkRead, {0x00, 30, 200, 24, 10, 112, 26, 10, 111, 26});
  const auto out = bus.dispatch(p, 1'000'000);
  ASSERT_EQ(out.size(), 3u);
  Bytes cm_data(30, 0);
  cm_data[38 - 24] = 0x00, cm_data[39 - 24] = 0x02;  // gyro Z 512
  cm_data[40 - 24] = 0x00, cm_data[41 - 24] = 0x02;
  cm_data[42 - 24] = 0x00, cm_data[43 - 24] = 0x02;
  cm_data[44 - 24] = 0x00, cm_data[45 - 24] = 0x02;  // ACC X 512
  cm_data[46 - 24] = 0x00, cm_data[47 - 24] = 0x02;
  cm_data[48 - 24] = 0x80, cm_data[49 - 24] = 0x02;  // ACC Z 640: 1 g at rest
  cm_data[50 - 24] = 148;                            // 14.8 V
  EXPECT_EQ(Bytes(out[0].packet->bytes.begin(), out[0].packet->bytes.begin() + out[0].packet->size),
            p1_status(200, 0, cm_data));
  EXPECT_EQ(Bytes(out[1].packet->bytes.begin(), out[1].packet->bytes.begin() + out[1].packet->size),
            p1_status(112, 0, {0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 0xA0, 0x0F, 152, 76}));  // X 6/10, Y 3/10 of 254
  EXPECT_TRUE(out[1].after_previous);
  EXPECT_EQ(out[2].device_id, 111);
}

TEST(DarwinBoards, FactoryGivesTheirRoles) {
  BuiltDevice cm = make_protocol1_device("CM-730", 200, 1'000'000, 0);
  EXPECT_NE(std::get<SimulatedController*>(cm.role), nullptr);
  BuiltDevice fsr = make_protocol1_device("DARWIN-FSR", 111, 1'000'000);
  EXPECT_EQ(std::get<SimulatedFootBoard*>(fsr.role), dynamic_cast<DarwinFsr*>(fsr.device.get()));
}

}  // namespace
}  // namespace doppel::dynamixel
