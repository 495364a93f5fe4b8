// Every servo model a robot file can name on a bus must also be able to drive a joint of its body:
// the physics needs motor constants for it.

#include <gtest/gtest.h>

#include "dynamixel/models.h"
#include "dynamixel/protocol2_models.h"
#include "physics/dc_motor.h"

namespace doppel::physics {
namespace {

TEST(MotorModels, EveryProtocol1ServoModelHasMotorConstants) {
  for (const dynamixel::ModelSpec* model : dynamixel::known_models()) {
    if (model->kind != dynamixel::DeviceKind::kServo) continue;

    EXPECT_TRUE(dc_motor_params(model->name).has_value()) << model->name;
  }
}

TEST(MotorModels, EveryProtocol2ServoModelHasMotorConstants) {
  for (const dynamixel::P2ModelSpec* model : dynamixel::known_p2_models()) {
    if (model->kind != dynamixel::P2DeviceKind::kServo) continue;

    EXPECT_TRUE(dc_motor_params(model->name).has_value()) << model->name;
  }
}

TEST(MotorModels, MxWithProtocol2FirmwareKeepsItsMotor) {
  const DcMotorParams v1 = *dc_motor_params("MX-64");

  const DcMotorParams v2 = *dc_motor_params("MX-64(2.0)");

  EXPECT_EQ(v2.stall_torque_nm, v1.stall_torque_nm);
  EXPECT_EQ(v2.back_emf_v_s_rad, v1.back_emf_v_s_rad);
  EXPECT_EQ(v2.resistance_ohm, v1.resistance_ohm);
}

}  // namespace
}  // namespace doppel::physics
