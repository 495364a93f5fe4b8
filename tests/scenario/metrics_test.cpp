// The scenario metrics on hand-made tracks whose answers are worked out by hand (distances by
// Pythagoras and rotation, the fall time where a linear tilt ramp crosses 45 degrees, energy as
// power x time), independent of any physics.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "scenario/metrics.h"

namespace doppel::scenario {
namespace {

Eigen::Isometry3d pose(double x, double y, double yaw) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X.translation() = Eigen::Vector3d(x, y, 0.0);
  return X;
}

TEST(ScenarioMetrics, DistanceForwardAndSidewaysFollowTheStartHeading) {
  // Start at (-1, 0.5) facing +y (yaw 90 deg); end at (-1.3, 0.9): 0.4 m along the heading, and
  // 0.3 m towards -x, which is the robot's left (facing +y, left is -x).
  MetricTrack track;
  const double yaw = std::numbers::pi / 2;
  track.start(pose(-1.0, 0.5, yaw));
  track.step(1.0, 0.001, pose(-1.3, 0.9, yaw), 0.0, 0.0, 0.0);
  const RobotMetrics& m = track.metrics();
  EXPECT_NEAR(m.distance_m, 0.5, 1e-12);  // 3-4-5
  EXPECT_NEAR(m.forward_m, 0.4, 1e-12);
  EXPECT_NEAR(m.lateral_m, 0.3, 1e-12) << "facing +y, the robot's left is -x";
  EXPECT_NEAR(m.end_x_m, -1.3, 1e-12);
  EXPECT_NEAR(m.end_y_m, 0.9, 1e-12);
  EXPECT_NEAR(m.end_yaw_rad, yaw, 1e-12);
}

TEST(ScenarioMetrics, WalkingBackwardsIsNegativeForward) {
  MetricTrack track;
  track.start(pose(0, 0, 0));
  track.step(1.0, 0.001, pose(-0.2, 0, 0.3), 0.0, 0.0, 0.0);
  EXPECT_NEAR(track.metrics().forward_m, -0.2, 1e-12);
  EXPECT_NEAR(track.metrics().distance_m, 0.2, 1e-12);
  EXPECT_NEAR(track.metrics().end_yaw_rad, 0.3, 1e-12) << "the end heading is the robot's, the distances the start's";
}

TEST(ScenarioMetrics, FallTimeIsTheFirstStepBeyond45DegreesAndPeakTiltIsTheLargest) {
  // Tilt rises 1 deg per 10 ms step from 0 to 90 deg at t = 0.01 .. 0.90 s, then settles at 80 deg.
  MetricTrack track;
  track.start(pose(0, 0, 0));
  const double deg = std::numbers::pi / 180;
  for (int i = 1; i <= 90; ++i) track.step(0.01 * i, 0.01, pose(0, 0, 0), i * deg, 0.0, 0.0);
  for (int i = 91; i <= 100; ++i) track.step(0.01 * i, 0.01, pose(0, 0, 0), 80 * deg, 0.0, 0.0);
  const RobotMetrics& m = track.metrics();
  ASSERT_TRUE(m.fall_time_s.has_value());
  EXPECT_NEAR(*m.fall_time_s, 0.46, 1e-12) << "46 deg is the first tilt beyond 45 deg";
  EXPECT_NEAR(m.peak_tilt_rad, 90 * deg, 1e-12);
  EXPECT_NEAR(m.peak_tilt_time_s, 0.90, 1e-12);
  EXPECT_NEAR(m.time_s, 1.0, 1e-12);
}

TEST(ScenarioMetrics, ExactlyAt45DegreesIsNotFallen) {
  MetricTrack track;
  track.start(pose(0, 0, 0));
  track.step(0.1, 0.1, pose(0, 0, 0), kFallTiltRad, 0.0, 0.0);
  EXPECT_FALSE(track.metrics().fall_time_s.has_value());
}

TEST(ScenarioMetrics, EnergyIsSupplyPowerIntegratedOverTime) {
  // 20 servos at 14.8 V drawing 0.1 A each for 2 s: 29.6 W x 2 s = 59.2 J; then 1 s regenerating
  // 5 W back into the supply: 54.2 J net.
  MetricTrack track;
  track.start(pose(0, 0, 0));
  for (int i = 1; i <= 2000; ++i) track.step(i * 0.001, 0.001, pose(0, 0, 0), 0.0, 20 * 14.8 * 0.1, 20 * 14.8 * 0.1);
  EXPECT_NEAR(track.metrics().energy_j, 59.2, 1e-9);
  for (int i = 2001; i <= 3000; ++i) track.step(i * 0.001, 0.001, pose(0, 0, 0), 0.0, -5.0, 0.0);
  EXPECT_NEAR(track.metrics().energy_j, 54.2, 1e-9);
  EXPECT_NEAR(track.metrics().energy_drawn_j, 59.2, 1e-9) << "regeneration does not count as drawn";
}

TEST(ScenarioMetrics, HeadingIsTheProjectedXAxis) {
  Eigen::Isometry3d X = pose(0, 0, 0.7);
  X.linear() = X.linear() * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();  // pitched
  EXPECT_NEAR(heading_rad(X), 0.7, 1e-12);
}

}  // namespace
}  // namespace doppel::scenario
