#include "scenario/metrics.h"

#include <cmath>

namespace doppel::scenario {

double heading_rad(const Eigen::Isometry3d& X_WR) noexcept {
  const Eigen::Vector3d x = X_WR.linear().col(0);
  return std::atan2(x.y(), x.x());
}

void MetricTrack::start(const Eigen::Isometry3d& X_WR) noexcept {
  start_xy_ = X_WR.translation().head<2>();
  start_yaw_ = heading_rad(X_WR);
  metrics_ = RobotMetrics{};
  metrics_.end_x_m = start_xy_.x();
  metrics_.end_y_m = start_xy_.y();
  metrics_.end_yaw_rad = start_yaw_;
}

void MetricTrack::step(double time_s, double dt_s, const Eigen::Isometry3d& X_WR, double tilt_rad,
                       double supply_power_w, double drawn_w) noexcept {
  const Eigen::Vector2d moved = X_WR.translation().head<2>() - start_xy_;
  const Eigen::Vector2d ahead(std::cos(start_yaw_), std::sin(start_yaw_));
  metrics_.distance_m = moved.norm();
  metrics_.forward_m = moved.dot(ahead);
  metrics_.lateral_m = ahead.x() * moved.y() - ahead.y() * moved.x();
  metrics_.end_x_m = X_WR.translation().x();
  metrics_.end_y_m = X_WR.translation().y();
  metrics_.end_yaw_rad = heading_rad(X_WR);
  if (tilt_rad > metrics_.peak_tilt_rad) {
    metrics_.peak_tilt_rad = tilt_rad;
    metrics_.peak_tilt_time_s = time_s;
  }
  if (!metrics_.fall_time_s && tilt_rad > kFallTiltRad) {
    metrics_.fall_time_s = time_s;
  }
  metrics_.energy_j += supply_power_w * dt_s;
  metrics_.energy_drawn_j += drawn_w * dt_s;
  metrics_.time_s = time_s;
}

}  // namespace doppel::scenario
