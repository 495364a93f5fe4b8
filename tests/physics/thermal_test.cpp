// The motor's thermal model: a servo stalled at its full torque overheats past the 80 C Temperature
// Limit of the RX series within about a minute and a half (the firmware then raises Overheating and,
// with the default Alarm Shutdown mask, switches torque off); unloaded it cools back.

#include <gtest/gtest.h>

#include <cmath>

#include "body/motor_params.h"
#include "physics/dc_motor.h"
#include "rigs.h"

namespace doppel::physics {
namespace {

TEST(ThermalModelTest, ApproachesAmbientPlusLossTimesThermalResistance) {
  const DcMotorParams params = doppel::body::motor_params("RX-64");
  ThermalModel sut(params, 25.0, 0.001);
  const double torque = 2.0;

  for (int i = 0; i < 60000; ++i) sut.step(torque);  // one time constant (60 s)

  const double current = torque / params.torque_constant_nm_a;
  const double steady = 25.0 + current * current * params.resistance_ohm * params.thermal_resistance_k_w;
  EXPECT_NEAR(sut.temperature_c(), steady + (25.0 - steady) * std::exp(-1.0), 1e-6);
}

TEST(ThermalModelTest, CoolsTowardAmbientWithoutCurrent) {
  ThermalModel sut(doppel::body::motor_params("RX-28"), 25.0, 0.001);
  sut.set_temperature_c(85.0);

  for (int i = 0; i < 50000; ++i) sut.step(0.0);  // one time constant (50 s)

  EXPECT_NEAR(sut.temperature_c(), 25.0 + 60.0 * std::exp(-1.0), 1e-6);
}

class StallTest : public ::testing::TestWithParam<std::string> {};

TEST_P(StallTest, StalledServoOverheatsAndRaisesOverload) {
  // An arm driven against its mechanical stop at +20 deg while its goal is far beyond: the motor
  // pushes at its full torque and cannot move (a servo blocked by an obstacle).
  const std::string rig =
      test::stall_rig(R"(baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "RX-64" name: "J" })");
  WorldOptions options = test::bare_options();
  auto world = test::make_world(GetParam(), {test::robot_from_text(rig)}, options);
  test::DrivenRobot driven(*world, 0);
  driven.enable_all();
  driven.command(0).goal_position_rad = 1.6;  // 92 deg: behind the stop

  double at_30_s = 0.0;
  bool overload = false;
  double crossed_at = -1.0;
  for (int i = 1; i <= 120000 && crossed_at < 0.0; ++i) {
    driven.step();
    const MotorState s = world->motor(driven.handle(0));
    overload = overload || driven.feedback(0).overload;  // the drive loop's controller
    if (i == 30000) at_30_s = s.temperature_c;
    if (s.temperature_c > 80.0) crossed_at = world->time_s();
  }

  EXPECT_LT(at_30_s, 80.0);   // not at once: a real motor takes tens of seconds
  EXPECT_GT(crossed_at, 30.0);
  EXPECT_LT(crossed_at, 120.0);  // but within two minutes of stall
  EXPECT_TRUE(overload);
  EXPECT_NEAR(world->motor(driven.handle(0)).torque_ratio, 1.0, 0.02);  // at the Torque Limit all along

  // Shutdown (torque off, as the Alarm Shutdown does): the motor cools.
  driven.disable_all();
  driven.run(10.0);
  EXPECT_LT(world->motor(driven.handle(0)).temperature_c, 80.0);
}

INSTANTIATE_TEST_SUITE_P(Engines, StallTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
