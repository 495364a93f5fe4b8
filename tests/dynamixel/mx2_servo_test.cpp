// MX servos with the Protocol 2.0 firmware (MX-28(2.0), MX-64(2.0), MX-106(2.0)): the X-series
// layout with the differences of shared/reference/dynamixel.md §3.6. Golden packets are framed with
// the reference's CRC (§2.1, §2.2) around the values the reference gives (model numbers §3.1,
// defaults §3.6); Doppel's choices (firmware 44, no FAST reads / BACKUP / Startup Configuration)
// are those of docs/devices.md P1 and P6.1.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <variant>
#include <vector>

#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol2.h"
#include "dynamixel/protocol2_factory.h"
#include "dynamixel/protocol2_servo.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::le;
using testing::p2::status;
using testing::p2::transact;
using testing::p2::write_params;

// Instructions as §2.1 frames them, CRC of §2.2 (no stuffing needed for these payloads).
Bytes instruction(uint8_t id, uint8_t inst, const Bytes& params = {}) {
  Bytes body = {inst};
  body.insert(body.end(), params.begin(), params.end());
  return testing::p2::frame(id, body);
}

Bytes write(Device& sut, uint16_t address, int64_t value, int size) {
  return transact(sut, instruction(1, instruction::kWrite, write_params(address, value, size)));
}

Bytes read(Device& sut, uint16_t address, uint16_t length) {
  Bytes p = le(address, 2);
  const Bytes l = le(length, 2);
  p.insert(p.end(), l.begin(), l.end());
  return transact(sut, instruction(1, instruction::kRead, p));
}

TEST(Mx2Models, PingAnswersModelNumberAndFirmware) {
  // §3.1: MX-28(2.0) 30, MX-64(2.0) 311, MX-106(2.0) 321; firmware 44 (docs/devices.md P1).
  const Bytes ping = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E};  // §2.2
  Protocol2Servo mx28(p2_model_spec("MX-28(2.0)"), 1, 3, 0);
  Protocol2Servo mx64(p2_model_spec("MX-64(2.0)"), 1, 3, 0);
  Protocol2Servo mx106(p2_model_spec("MX-106(2.0)"), 1, 3, 0);
  EXPECT_EQ(transact(mx28, ping), (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0x1E, 0x00, 0x2C, 0xBA, 0xC4}));
  EXPECT_EQ(transact(mx64, ping), (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0x37, 0x01, 0x2C, 0x8E, 0xC0}));
  EXPECT_EQ(transact(mx106, ping), (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0x41, 0x01, 0x2C, 0x35, 0x46}));
}

TEST(Mx2Models, FactoryDefaultsOfTheReference) {
  Protocol2Servo mx28(p2_model_spec("MX-28(2.0)"), 1, 1, 250);
  Protocol2Servo mx64(p2_model_spec("MX-64(2.0)"), 1, 1, 250);
  Protocol2Servo mx106(p2_model_spec("MX-106(2.0)"), 1, 1, 250);
  struct Row {
    uint16_t address;
    int64_t mx28, mx64, mx106;
  };
  const Row rows[] = {
      {x430::kBaudRate, 1, 1, 1},
      {x430::kMinVoltageLimit, 95, 95, 95},
      {x430::kMaxVoltageLimit, 160, 160, 160},
      {x430::kPwmLimit, 885, 885, 885},
      {x430::kAccelerationLimit, 32767, 32767, 32767},
      {x430::kVelocityLimit, 380, 435, 360},
      {x430::kShutdown, 52, 52, 52},
      {x430::kVelocityIGain, 1920, 1920, 1920},
      {x430::kVelocityPGain, 100, 100, 100},
      {x430::kPositionDGain, 0, 0, 0},
      {x430::kPositionIGain, 0, 0, 0},
      {x430::kPositionPGain, 850, 850, 850},
      {x430::kOperatingMode, 3, 3, 3},
      {x430::kProtocolType, 2, 2, 2},
      {x430::kCurrentLimit, 0, 1941, 2047},  // MX-28(2.0) has none (reads 0)
      {x430::kGoalCurrent, 0, 1941, 2047},   // power-on value = Current Limit
      {x430::kGoalPwm, 885, 885, 885},
  };
  for (const Row& r : rows) {
    EXPECT_EQ(mx28.register_value(r.address), r.mx28) << r.address;
    EXPECT_EQ(mx64.register_value(r.address), r.mx64) << r.address;
    EXPECT_EQ(mx106.register_value(r.address), r.mx106) << r.address;
  }
  // Over the bus: Velocity Limit (44, 4 B) of the MX-28(2.0) = 380.
  EXPECT_EQ(read(mx28, x430::kVelocityLimit, 4), status(1, 0, le(380, 4)));
}

TEST(Mx2Models, Mx28HasNoCurrentItemsAndReportsLoad) {
  Protocol2Servo sut(p2_model_spec("MX-28(2.0)"), 1, 3, 0);
  // §3.6: no Current Limit (38), no Goal Current (102): writing them is an undefined address (§2.5).
  EXPECT_EQ(write(sut, x430::kCurrentLimit, 100, 2), status(1, p2_error::kAccess));
  EXPECT_EQ(write(sut, x430::kGoalCurrent, 100, 2), status(1, p2_error::kAccess));
  // Reserved bytes inside the table read 0 (docs/devices.md P4).
  EXPECT_EQ(read(sut, x430::kCurrentLimit, 2), status(1, 0, {0, 0}));
  // 126 = Present Load in 0.1 % (as the XL430): half the stall torque reads 500.
  ServoFeedback f;
  f.torque_ratio = 0.5;
  sut.apply(f);
  EXPECT_EQ(read(sut, x430::kPresentLoad, 2), status(1, 0, le(500, 2)));
}

TEST(Mx2Models, Mx64PresentCurrentIn336MilliampUnits) {
  Protocol2Servo sut(p2_model_spec("MX-64(2.0)"), 1, 3, 0);
  ServoFeedback f;
  f.current_a = 2.05;  // 610 x 3.36 mA
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kPresentCurrent), 610);
}

TEST(Mx2Models, OperatingModesOfTheReference) {
  // §3.6: MX-28(2.0) 1, 3, 4, 16; MX-64/106(2.0) 0, 1, 3, 4, 5, 16. Others: Data Range (§2.5).
  Protocol2Servo mx28(p2_model_spec("MX-28(2.0)"), 1, 3, 0);
  Protocol2Servo mx106(p2_model_spec("MX-106(2.0)"), 1, 3, 0);
  for (int mode : {0, 2, 5, 6, 17}) {
    EXPECT_EQ(write(mx28, x430::kOperatingMode, mode, 1), status(1, p2_error::kDataRange)) << mode;
  }
  for (int mode : {1, 3, 4, 16}) {
    EXPECT_EQ(write(mx28, x430::kOperatingMode, mode, 1), status(1, 0)) << mode;
  }
  for (int mode : {2, 6, 17}) {
    EXPECT_EQ(write(mx106, x430::kOperatingMode, mode, 1), status(1, p2_error::kDataRange)) << mode;
  }
  for (int mode : {0, 1, 3, 4, 5, 16}) {
    EXPECT_EQ(write(mx106, x430::kOperatingMode, mode, 1), status(1, 0)) << mode;
  }
}

TEST(Mx2Models, DriveModeBits) {
  // Bit 0 reverse and bit 2 time-based profile on every MX(2.0); bit 1 master/slave on the
  // MX-106(2.0) only (§3.6); bit 3 (torque on by goal) is X fw >= 45.
  Protocol2Servo mx64(p2_model_spec("MX-64(2.0)"), 1, 3, 0);
  Protocol2Servo mx106(p2_model_spec("MX-106(2.0)"), 1, 3, 0);
  EXPECT_EQ(write(mx64, x430::kDriveMode, 0x05, 1), status(1, 0));
  EXPECT_EQ(write(mx64, x430::kDriveMode, 0x02, 1), status(1, p2_error::kDataRange));
  EXPECT_EQ(write(mx64, x430::kDriveMode, 0x08, 1), status(1, p2_error::kDataRange));
  EXPECT_EQ(write(mx106, x430::kDriveMode, 0x02, 1), status(1, 0));
  EXPECT_EQ(write(mx106, x430::kDriveMode, 0x08, 1), status(1, p2_error::kDataRange));
}

TEST(Mx2Models, GoalCurrentRangeAndLimit) {
  Protocol2Servo sut(p2_model_spec("MX-64(2.0)"), 1, 3, 0);
  EXPECT_EQ(write(sut, x430::kGoalCurrent, 1942, 2), status(1, p2_error::kDataRange));  // item range +-1941
  EXPECT_EQ(write(sut, x430::kCurrentLimit, 1000, 2), status(1, 0));
  EXPECT_EQ(write(sut, x430::kGoalCurrent, -1001, 2), status(1, p2_error::kDataLimit));  // |goal| > Current Limit
  EXPECT_EQ(write(sut, x430::kGoalCurrent, -1000, 2), status(1, 0));
}

TEST(Mx2Models, CurrentModeCommandsTorqueFromGoalCurrent) {
  Protocol2Servo sut(p2_model_spec("MX-106(2.0)"), 1, 3, 0);
  ASSERT_EQ(write(sut, x430::kOperatingMode, x430::kCurrentMode, 1), status(1, 0));
  ASSERT_EQ(write(sut, x430::kGoalCurrent, 774, 2), status(1, 0));  // 774 x 3.36 mA = 2.6 A = half of 5.2 A
  ASSERT_EQ(write(sut, x430::kTorqueEnable, 1, 1), status(1, 0));
  const ServoCommand c = sut.command();
  EXPECT_TRUE(c.torque_control);
  EXPECT_NEAR(c.goal_current_a, 774 * 0.00336, 1e-9);
}

TEST(Mx2Models, NoStartupConfigurationBackupOrFastReads) {
  // Documented for X (and P) firmware only (§2.4, §3.7): the MX(2.0) firmware has none of them.
  Protocol2Servo sut(p2_model_spec("MX-64(2.0)"), 1, 3, 0);
  EXPECT_EQ(write(sut, x430::kStartupConfiguration, 1, 1), status(1, p2_error::kAccess));
  // BACKUP store (§2.4 golden instruction) -> Instruction Error.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x20, 0x01, 0x43, 0x54, 0x52, 0x4C, 0x16, 0xF5}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x02, 0xAE, 0x8C}));
  // FAST SYNC READ: to the broadcast ID it is an unknown instruction (silent), to the ID an Instruction Error.
  EXPECT_TRUE(transact(sut, instruction(0xFE, instruction::kFastSyncRead, {0x84, 0x00, 0x04, 0x00, 1})).empty());
  EXPECT_TRUE(transact(sut, instruction(0xFE, instruction::kFastBulkRead, {1, 0x84, 0x00, 0x04, 0x00})).empty());
  EXPECT_EQ(transact(sut, instruction(1, instruction::kFastSyncRead, {0x84, 0x00, 0x04, 0x00, 1})),
            status(1, p2_error::kInstruction));
  // The plain SYNC READ works.
  EXPECT_EQ(transact(sut, instruction(0xFE, instruction::kSyncRead, {0x84, 0x00, 0x04, 0x00, 1})),
            status(1, 0, le(2048, 4)));
}

TEST(Mx2Models, FastSyncReadWithAnMxBreaksTheCombinedStatus) {
  // An XM430 and an MX-64(2.0) in one FAST SYNC READ: the MX never sends its block, so the
  // combined status stops after the XM's (docs/devices.md P5: an absent block breaks the chain).
  Protocol2Servo xm(p2_model_spec("XM430-W350"), 1, 3, 0);
  Protocol2Servo mx(p2_model_spec("MX-64(2.0)"), 2, 3, 0);
  BusDevices bus;
  bus.add(xm);
  bus.add(mx);
  const auto statuses = bus.dispatch(testing::p2::parse(instruction(0xFE, instruction::kFastSyncRead, {0x84, 0x00, 0x04, 0x00, 1, 2})),
                                     1000000);
  ASSERT_EQ(statuses.size(), 1u);
  EXPECT_EQ(statuses[0].device_id, 1);
}

TEST(Mx2Models, FactoryBuildsThemByName) {
  const BuiltDevice sut = make_protocol2_device("MX-106(2.0)", 7, 4000000);
  auto* servo = dynamic_cast<Protocol2Servo*>(sut.device.get());
  ASSERT_NE(servo, nullptr);
  EXPECT_EQ(std::get<SimulatedServo*>(sut.role), servo);
  EXPECT_EQ(servo->model_number(), 321);
  EXPECT_EQ(servo->id(), 7);
  EXPECT_EQ(servo->register_value(x430::kBaudRate), 6);  // §3.3: 6 = 4 Mbps
  EXPECT_EQ(servo->baud_bps(), 4000000u);
  EXPECT_THROW(make_protocol2_device("MX-28", 1, 1000000), std::invalid_argument);  // the P1 firmware's name
}

TEST(Mx2Models, PhysicalDataFromTheDatasheet) {
  // §5 at 12 V: MX-28 2.5 N·m / 1.4 A / 55 rpm, gear 193; MX-64 6.0 / 4.1 / 63, 200; MX-106 8.4 / 5.2 / 45, 225.
  struct Row {
    const char* name;
    double torque, current, rpm, gear;
  };
  for (const Row& r : {Row{"MX-28(2.0)", 2.5, 1.4, 55, 193}, Row{"MX-64(2.0)", 6.0, 4.1, 63, 200},
                       Row{"MX-106(2.0)", 8.4, 5.2, 45, 225}}) {
    const MotorSpec& m = *p2_model_spec(r.name).servo.motor;
    EXPECT_DOUBLE_EQ(m.stall_torque_nm, r.torque) << r.name;
    EXPECT_DOUBLE_EQ(m.stall_current_a, r.current) << r.name;
    EXPECT_DOUBLE_EQ(m.no_load_speed_rpm, r.rpm) << r.name;
    EXPECT_DOUBLE_EQ(m.gear_ratio, r.gear) << r.name;
    EXPECT_NEAR(m.torque_constant_nm_a, r.torque / r.current, 1e-12) << r.name;
    EXPECT_NEAR(m.resistance_ohm, 12.0 / r.current, 1e-12) << r.name;
    // At the no-load speed the motor's torque just balances its gear friction.
    const double w = r.rpm * 2.0 * std::numbers::pi / 60.0;
    EXPECT_NEAR(m.torque_constant_nm_a * (12.0 - m.back_emf_v_s_rad * w) / m.resistance_ohm,
                m.friction_nm + m.viscous_friction_nm_s_rad * w, 1e-9)
        << r.name;
  }
}

}  // namespace
}  // namespace doppel::dynamixel
