#pragma once
// The measurements of one robot during a scenario run (docs/scenarios.md defines each), accumulated
// step by step on the simulation thread: plain arithmetic on what the world reports, no allocation,
// so that the same code is fed by the physics in a run and by hand-made tracks in the tests.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

namespace doppel::scenario {

// Tilt beyond which a robot counts as fallen: contract::kFallenTiltRad (45 degrees), the viewer's
// and doppel-ctl's `fallen`.
inline constexpr double kFallTiltRad = 0.7853981633974483;

struct RobotMetrics {
  // Where the robot frame's origin went on the floor, from its start to the end of the run.
  double distance_m = 0.0;  // straight line
  double forward_m = 0.0;   // along its start heading
  double lateral_m = 0.0;   // to the left of it
  double end_x_m = 0.0, end_y_m = 0.0, end_yaw_rad = 0.0;
  double peak_tilt_rad = 0.0;    // largest angle of the robot frame's z axis against the vertical
  double peak_tilt_time_s = 0.0;
  std::optional<double> fall_time_s;  // first time the tilt exceeded kFallTiltRad
  double energy_j = 0.0;         // integral of the servos' summed supply power (V x I), net
  double energy_drawn_j = 0.0;   // the same counting only what each servo drew (no regeneration)
  double time_s = 0.0;           // simulated time measured
};

class MetricTrack {
 public:
  // The robot's pose at the start (time 0).
  void start(const Eigen::Isometry3d& X_WR) noexcept;
  // After a step of `dt_s` ending at `time_s`: the robot's pose, its tilt, and the power its servos
  // drew from their supply during the step (sum of supply voltage x supply current, W; `drawn_w`
  // the sum of the servos' positive powers only).
  void step(double time_s, double dt_s, const Eigen::Isometry3d& X_WR, double tilt_rad, double supply_power_w,
            double drawn_w) noexcept;
  const RobotMetrics& metrics() const noexcept { return metrics_; }

 private:
  Eigen::Vector2d start_xy_ = Eigen::Vector2d::Zero();
  double start_yaw_ = 0.0;
  RobotMetrics metrics_;
};

// Heading of a robot frame: the angle of its x axis projected on the floor, rad.
double heading_rad(const Eigen::Isometry3d& X_WR) noexcept;

}  // namespace doppel::scenario
