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
  EXPECT_EQ(sut.friction.law, physics::FrictionLaw::kM1);
  EXPECT_NEAR(sut.friction.coulomb_nm, 0.106, 1e-12);
  EXPECT_FALSE(sut.powered_friction);
  EXPECT_GT(sut.thermal_resistance_k_w, 0.0);
  EXPECT_GT(sut.thermal_time_constant_s, 0.0);
  EXPECT_GT(sut.friction.viscous_nm_s_rad, 0.0);
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

  EXPECT_EQ(sut("XL430-W250", 0)->torque_constant_nm_a, motor_params("XL430-W250").torque_constant_nm_a);
  EXPECT_FALSE(sut("BITBOTS-CORE", 0).has_value());
  EXPECT_EQ(sut("MX-64", 6)->friction.law, physics::FrictionLaw::kM6);
  EXPECT_FALSE(sut("MX-28", 6).has_value());  // BAM did not identify it
  EXPECT_FALSE(sut("MX-64", 7).has_value());
}

// Rhoban/bam bam/params/mx64/m6.json and mx106/m1.json (commit 1b5a1ce), as published; the registry
// keeps six significant digits (half a unit of the sixth: 5e-6 relative).
TEST(MotorParams, BamIdentificationsCarryThePublishedNumbers) {
  const physics::DcMotorParams m6 = motor_params("MX-64", 6);
  EXPECT_NEAR(m6.torque_constant_nm_a, 1.6016832750318712, 5e-6 * 1.6016832750318712);
  EXPECT_NEAR(m6.back_emf_v_s_rad, 1.6016832750318712, 5e-6 * 1.6016832750318712);  // BAM's motor: ke = kt
  EXPECT_NEAR(m6.resistance_ohm, 2.3164043271967447, 5e-6 * 2.3164043271967447);
  EXPECT_NEAR(m6.armature_kg_m2, 0.012265893049213158, 5e-6 * 0.012265893049213158);
  EXPECT_TRUE(m6.powered_friction);
  EXPECT_EQ(m6.friction.law, physics::FrictionLaw::kM6);
  EXPECT_NEAR(m6.friction.viscous_nm_s_rad, 0.02533701181690149, 5e-6 * 0.02533701181690149);
  EXPECT_NEAR(m6.friction.stribeck_nm, 0.12269525980968875, 5e-6 * 0.12269525980968875);
  EXPECT_NEAR(m6.friction.stribeck_velocity_rad_s, 2.575277366960116, 5e-6 * 2.575277366960116);
  EXPECT_NEAR(m6.friction.stribeck_alpha, 0.8409018066017007, 5e-6 * 0.8409018066017007);
  EXPECT_NEAR(m6.friction.load_motor, 0.3114720375111298, 5e-6 * 0.3114720375111298);
  EXPECT_NEAR(m6.friction.load_motor_stribeck, 0.18774381222411038, 5e-6 * 0.18774381222411038);
  EXPECT_NEAR(m6.friction.load_external_stribeck, 0.014065853481003015, 5e-6 * 0.014065853481003015);
  EXPECT_NEAR(m6.friction.quadratic_motor_per_nm, 0.006908512882777861, 5e-6 * 0.006908512882777861);
  EXPECT_NEAR(m6.friction.quadratic_external_per_nm, 0.009999980627672081, 5e-6 * 0.009999980627672081);
  // The datasheet figures stay: the Torque Limit still caps at the datasheet stall torque.
  EXPECT_DOUBLE_EQ(m6.stall_torque_nm, motor_params("MX-64").stall_torque_nm);

  const physics::DcMotorParams m1 = motor_params("MX-106", 1);
  EXPECT_NEAR(m1.torque_constant_nm_a, 2.1913757006745245, 5e-6 * 2.1913757006745245);
  EXPECT_NEAR(m1.resistance_ohm, 2.9649903987776804, 5e-6 * 2.9649903987776804);
  EXPECT_NEAR(m1.armature_kg_m2, 0.026609234235148084, 5e-6 * 0.026609234235148084);
  EXPECT_NEAR(m1.friction.coulomb_nm, 0.10352026623606064, 5e-6 * 0.10352026623606064);
  EXPECT_NEAR(m1.friction.viscous_nm_s_rad, 0.03520238029013507, 5e-6 * 0.03520238029013507);
  EXPECT_EQ(m1.friction.law, physics::FrictionLaw::kM1);

  // The MX(2.0) firmware runs the same motor and gear train.
  EXPECT_DOUBLE_EQ(motor_params("MX-106(2.0)", 4).resistance_ohm, motor_params("MX-106", 4).resistance_ohm);
  try {
    (void)motor_params("XM430-W350", 2);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("XM430-W350"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("M2"), std::string::npos);
  }
}

}  // namespace
}  // namespace doppel::body
