// Every servo model a robot file can name on a bus must also be able to drive a joint of its body:
// the physics gets motor constants for it, the registry's numbers, and nothing for a board.

#include "body/motor_params.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "dynamixel/model_registry.h"

namespace doppel::body {
namespace {

TEST(MotorParams, EveryProtocol1ServoModelHasMotorConstants) {
  for (const dynamixel::ModelSpec* model : dynamixel::known_models()) {
    if (model->kind != dynamixel::DeviceKind::kServo) continue;

    EXPECT_TRUE(find_motor_params(model->name).has_value()) << model->name;
  }
}

TEST(MotorParams, EveryProtocol2ServoModelHasMotorConstants) {
  for (const dynamixel::P2ModelSpec* model : dynamixel::known_p2_models()) {
    if (model->kind != dynamixel::P2DeviceKind::kServo) continue;

    EXPECT_TRUE(find_motor_params(model->name).has_value()) << model->name;
  }
}

TEST(MotorParams, MxWithProtocol2FirmwareKeepsItsMotor) {
  const physics::DcMotorParams v1 = motor_params("MX-64");

  const physics::DcMotorParams v2 = motor_params("MX-64(2.0)");

  EXPECT_EQ(v2.stall_torque_nm, v1.stall_torque_nm);
  EXPECT_EQ(v2.back_emf_v_s_rad, v1.back_emf_v_s_rad);
  EXPECT_EQ(v2.resistance_ohm, v1.resistance_ohm);
}

TEST(MotorParams, CarriesTheRegistrysNumbers) {
  // RX-64: thesis Table 7 (ke 2.82, R 0.75, kt 3.2), datasheet 5.3 N m at 18.5 V (reference §5),
  // gear friction 2 % of the stall torque.
  const physics::DcMotorParams sut = motor_params("RX-64");

  EXPECT_DOUBLE_EQ(sut.back_emf_v_s_rad, 2.82);
  EXPECT_DOUBLE_EQ(sut.resistance_ohm, 0.75);
  EXPECT_DOUBLE_EQ(sut.torque_constant_nm_a, 3.2);
  EXPECT_DOUBLE_EQ(sut.stall_torque_nm, 5.3);
  EXPECT_DOUBLE_EQ(sut.rated_voltage_v, 18.5);
  EXPECT_NEAR(sut.friction_nm, 0.106, 1e-12);
  EXPECT_GT(sut.thermal_resistance_k_w, 0.0);
  EXPECT_GT(sut.thermal_time_constant_s, 0.0);
  EXPECT_GT(sut.viscous_friction_nm_s_rad, 0.0);
}

TEST(MotorParams, BoardsAndUnknownNamesHaveNone) {
  EXPECT_FALSE(find_motor_params("FUMANOID-IMU").has_value());
  EXPECT_FALSE(find_motor_params("BITFOOT").has_value());
  EXPECT_FALSE(find_motor_params("AX-18A").has_value());
  try {
    (void)motor_params("AX-18A");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("AX-18A"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("XM430-W350"), std::string::npos);  // the known servos
  }
}

TEST(MotorParams, CatalogIsTheLookup) {
  const physics::MotorCatalog sut = motor_catalog();

  EXPECT_EQ(sut("XL430-W250")->torque_constant_nm_a, motor_params("XL430-W250").torque_constant_nm_a);
  EXPECT_FALSE(sut("BITBOTS-CORE").has_value());
}

}  // namespace
}  // namespace doppel::body
