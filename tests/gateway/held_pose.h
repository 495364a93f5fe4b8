#pragma once
// What the held-until-torque tests of the default robot and of fumanoid-x430 expect of the trunk
// and the feet of a held robot, whose pose types differ only in how they are read.

#include <gtest/gtest.h>

#include <cmath>

namespace doppel::testing {

// The trunk stays level within 0.5 deg and drifts by less than 0.05 deg (the FUmanoid IMU resolves
// 0.006 deg); the feet keep their load within 1.5 N (ODE's contact jitter on a held robot is about
// 1 N, a falling robot's loads change by tens of N).
inline constexpr double kHeldLevelDeg = 0.5;
inline constexpr double kHeldDriftDeg = 0.05;
inline constexpr double kHeldFeetN = 1.5;

// `settled`: read once the feet have settled on the carpet; `held`: read seconds later. Pose has
// pitch_deg, roll_deg and feet_n.
template <class Pose>
void expect_held_still(const Pose& settled, const Pose& held) {
  EXPECT_LT(std::fabs(held.pitch_deg), kHeldLevelDeg) << held.pitch_deg;
  EXPECT_LT(std::fabs(held.roll_deg), kHeldLevelDeg) << held.roll_deg;
  EXPECT_NEAR(held.pitch_deg, settled.pitch_deg, kHeldDriftDeg);
  EXPECT_NEAR(held.roll_deg, settled.roll_deg, kHeldDriftDeg);
  EXPECT_GT(held.feet_n, 1.0) << "the feet rest on the carpet";
  EXPECT_NEAR(held.feet_n, settled.feet_n, kHeldFeetN);
}

}  // namespace doppel::testing
