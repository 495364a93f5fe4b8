#include "truth/world_model.h"

#include <cmath>
#include <numbers>
#include <set>
#include <sstream>

namespace doppel::truth {
namespace {

using contract::WorldModelSettings;

std::string number_text(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

double wrap(double angle_rad) { return std::remainder(angle_rad, 2.0 * std::numbers::pi); }

// A seen object's position after the position noise: one 2-D Gaussian draw.
struct Noisy {
  double x_m, y_m;
};

}  // namespace

std::string settings_problem(const WorldModelSettings& s) {
  auto bad = [](const char* field, const std::string& rule, double got) {
    return std::string(field) + " must be " + rule + ", got " + number_text(got);
  };
  if (!(s.rate_hz > 0.0 && s.rate_hz <= 1000.0)) return bad("rate_hz", "within (0, 1000] Hz", s.rate_hz);
  if (!(s.fov_deg == 0.0 || (s.fov_deg > 0.0 && s.fov_deg < 180.0))) {
    return bad("fov_deg", "0 (all around) or within (0, 180) degrees", s.fov_deg);
  }
  if (!(s.max_range_m >= 0.0 && std::isfinite(s.max_range_m))) return bad("max_range_m", "0 (no limit) or positive", s.max_range_m);
  if (!(s.position_sigma_m >= 0.0 && s.position_sigma_m <= 10.0)) return bad("position_sigma_m", "within [0, 10] m", s.position_sigma_m);
  if (!(s.angle_sigma_rad >= 0.0 && s.angle_sigma_rad <= 10.0)) return bad("angle_sigma_rad", "within [0, 10] rad", s.angle_sigma_rad);
  if (!(s.dropout >= 0.0 && s.dropout < 1.0)) return bad("dropout", "within [0, 1)", s.dropout);
  if (!(s.latency_s >= 0.0 && s.latency_s <= 1.0)) return bad("latency_s", "within [0, 1] s", s.latency_s);
  return "";
}

FieldObjects field_objects(const physics::FieldSpec& spec) {
  FieldObjects out;
  std::set<uint16_t> poles_seen;
  for (const physics::VisualShape& shape : physics::field_shapes(spec)) {
    const double x = shape.X_WS.translation().x(), y = shape.X_WS.translation().y();
    if (shape.kind == physics::ObjectKind::kGoalPost) {
      FieldObjects::Post post;
      const uint16_t id = shape.object_id;
      post.goal = id == physics::kYellowGoalLeftPostId || id == physics::kYellowGoalRightPostId
                      ? proto::truth::GoalPost::YELLOW
                      : proto::truth::GoalPost::BLUE;
      post.left = id == physics::kYellowGoalLeftPostId || id == physics::kBlueGoalLeftPostId;
      post.x_m = x;
      post.y_m = y;
      out.posts.push_back(post);
    } else if (shape.kind == physics::ObjectKind::kSidePole && poles_seen.insert(shape.object_id).second) {
      out.poles.push_back({shape.object_id == physics::kLeftPoleId, x, y});  // its bands share x, y
    }
  }
  const double penalty_x = 0.5 * spec.field_length_m - spec.penalty_mark_distance_m;
  for (const physics::FieldFeature& feature : physics::field_features(spec)) {
    FieldObjects::Mark mark;
    mark.x_m = feature.position_W.x();
    mark.y_m = feature.position_W.y();
    mark.heading_rad = feature.heading_rad;
    switch (feature.type) {
      case physics::FieldFeatureType::kL: mark.type = proto::truth::Landmark::L_CROSSING; break;
      case physics::FieldFeatureType::kT: mark.type = proto::truth::Landmark::T_CROSSING; break;
      case physics::FieldFeatureType::kX:
        mark.type = std::abs(std::abs(mark.x_m) - penalty_x) < 1e-9 && std::abs(mark.y_m) < 1e-9
                        ? proto::truth::Landmark::PENALTY_MARK
                        : proto::truth::Landmark::X_CROSSING;
        break;
    }
    out.marks.push_back(mark);
  }
  out.marks.push_back({proto::truth::Landmark::CENTRE_CIRCLE, 0.0, 0.0, 0.0});
  return out;
}

proto::truth::Relative relative_to(double robot_x_m, double robot_y_m, double robot_yaw_rad, double x_m, double y_m) {
  const double dx = x_m - robot_x_m, dy = y_m - robot_y_m;
  const double c = std::cos(robot_yaw_rad), s = std::sin(robot_yaw_rad);
  proto::truth::Relative r;
  r.set_x_m(c * dx + s * dy);
  r.set_y_m(-s * dx + c * dy);
  r.set_distance_m(std::hypot(r.x_m(), r.y_m()));
  r.set_bearing_rad(std::atan2(r.y_m(), r.x_m()));
  return r;
}

bool in_view(const RobotSample& robot, const WorldModelSettings& settings, double x_m, double y_m) {
  const double dx = x_m - robot.view_x_m, dy = y_m - robot.view_y_m;
  const double distance = std::hypot(dx, dy);
  if (settings.max_range_m > 0.0 && distance > settings.max_range_m) return false;
  if (settings.fov_deg <= 0.0 || distance < 1e-9) return true;
  const double off_axis = std::abs(wrap(std::atan2(dy, dx) - robot.view_yaw_rad));
  return off_axis <= 0.5 * settings.fov_deg * std::numbers::pi / 180.0;
}

proto::truth::WorldModel build_world_model(const WorldSample& sample, std::size_t robot, const WorldModelSettings& settings,
                                           const FieldObjects& field, std::mt19937_64& rng, int64_t sim_time_ns,
                                           uint64_t sequence) {
  const RobotSample& me = sample.robots[robot];
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  // A draw of zero sigma leaves the value exact and takes nothing from the sequence.
  auto position_noise = [&](double x, double y) -> Noisy {
    if (settings.position_sigma_m <= 0.0) return {x, y};
    const double nx = gauss(rng), ny = gauss(rng);
    return {x + settings.position_sigma_m * nx, y + settings.position_sigma_m * ny};
  };
  auto angle_noise = [&](double a) { return settings.angle_sigma_rad <= 0.0 ? a : wrap(a + settings.angle_sigma_rad * gauss(rng)); };
  auto dropped = [&] { return settings.dropout > 0.0 && uniform(rng) < settings.dropout; };
  auto seen = [&](double x, double y) { return in_view(me, settings, x, y); };
  // The object's noisy position in the field frame and, as the same point, relative to the robot's true pose.
  auto place = [&](proto::truth::Position* position, proto::truth::Relative* relative, double x, double y) {
    const Noisy n = position_noise(x, y);
    position->set_x_m(n.x_m);
    position->set_y_m(n.y_m);
    *relative = relative_to(me.x_m, me.y_m, me.yaw_rad, n.x_m, n.y_m);
  };

  proto::truth::WorldModel out;
  out.set_robot(static_cast<uint32_t>(robot));
  out.set_team(me.team);
  out.set_sequence(sequence);
  out.set_sim_time_ns(sim_time_ns);
  out.set_world_time_ns(sample.sim_time_ns);
  out.set_fov_deg(settings.fov_deg);
  out.set_max_range_m(settings.max_range_m);
  out.set_nearest_ball_only(settings.nearest_ball_only);
  out.set_position_sigma_m(settings.position_sigma_m);
  out.set_angle_sigma_rad(settings.angle_sigma_rad);
  out.set_dropout(settings.dropout);
  out.set_latency_s(settings.latency_s);
  out.set_view_yaw_rad(wrap(me.view_yaw_rad));
  {
    const Noisy p = position_noise(me.x_m, me.y_m);
    proto::truth::Pose2D* pose = out.mutable_pose();
    pose->set_x_m(p.x_m);
    pose->set_y_m(p.y_m);
    pose->set_yaw_rad(angle_noise(wrap(me.yaw_rad)));
  }

  // Balls: the ones in view; of those only the nearest (true distance) with nearest_ball_only.
  std::size_t nearest = kMaxBalls;
  double nearest_distance = 0.0;
  std::array<bool, kMaxBalls> ball_seen{};
  for (std::size_t b = 0; b < sample.ball_count && b < kMaxBalls; ++b) {
    const auto& c = sample.balls[b];
    ball_seen[b] = seen(c[0], c[1]);
    const double d = std::hypot(c[0] - me.x_m, c[1] - me.y_m);
    if (ball_seen[b] && (nearest == kMaxBalls || d < nearest_distance)) {
      nearest = b;
      nearest_distance = d;
    }
  }
  for (std::size_t b = 0; b < sample.ball_count && b < kMaxBalls; ++b) {
    if (!ball_seen[b] || (settings.nearest_ball_only && b != nearest) || dropped()) continue;
    proto::truth::Ball* ball = out.add_balls();
    ball->set_index(static_cast<uint32_t>(b));
    ball->set_z_m(sample.balls[b][2]);
    place(ball->mutable_field(), ball->mutable_relative(), sample.balls[b][0], sample.balls[b][1]);
  }
  for (const FieldObjects::Post& p : field.posts) {
    if (!seen(p.x_m, p.y_m) || dropped()) continue;
    proto::truth::GoalPost* post = out.add_goal_posts();
    post->set_goal(p.goal);
    post->set_left(p.left);
    place(post->mutable_field(), post->mutable_relative(), p.x_m, p.y_m);
  }
  for (const FieldObjects::Pole& p : field.poles) {
    if (!seen(p.x_m, p.y_m) || dropped()) continue;
    proto::truth::SidePole* pole = out.add_side_poles();
    pole->set_left(p.left);
    place(pole->mutable_field(), pole->mutable_relative(), p.x_m, p.y_m);
  }
  for (const FieldObjects::Mark& m : field.marks) {
    if (!seen(m.x_m, m.y_m) || dropped()) continue;
    proto::truth::Landmark* mark = out.add_landmarks();
    mark->set_type(m.type);
    mark->set_heading_rad(m.type == proto::truth::Landmark::CENTRE_CIRCLE ? 0.0 : angle_noise(m.heading_rad));
    place(mark->mutable_field(), mark->mutable_relative(), m.x_m, m.y_m);
  }
  for (std::size_t r = 0; r < kMaxRobots; ++r) {
    const RobotSample& other = sample.robots[r];
    if (r == robot || !other.present || !seen(other.x_m, other.y_m) || dropped()) continue;
    proto::truth::Robot* o = out.add_robots();
    o->set_index(static_cast<uint32_t>(r));
    o->set_team(other.team);
    proto::truth::Position position;
    place(&position, o->mutable_relative(), other.x_m, other.y_m);
    const double yaw = angle_noise(wrap(other.yaw_rad));
    o->mutable_pose()->set_x_m(position.x_m());
    o->mutable_pose()->set_y_m(position.y_m());
    o->mutable_pose()->set_yaw_rad(yaw);
    o->set_relative_yaw_rad(wrap(yaw - me.yaw_rad));
  }
  return out;
}

WorldModelTopic::WorldModelTopic(const physics::FieldSpec& spec, double history_s)
    : field_(field_objects(spec)), history_(static_cast<std::size_t>(std::ceil(history_s * 1000.0)) + 2) {}

std::string WorldModelTopic::set(std::size_t robot, const WorldModelSettings& settings) {
  if (robot >= kMaxRobots) return "robot " + std::to_string(robot) + " is beyond the " + std::to_string(kMaxRobots) + " robots";
  if (std::string problem = settings_problem(settings); !problem.empty()) return problem;
  auto [it, added] = sensors_.try_emplace(robot);
  Sensor& sensor = it->second;
  if (added || sensor.settings.seed != settings.seed) sensor.rng.seed(settings.seed * 0x9E3779B97F4A7C15ULL + robot);
  if (added || sensor.settings.rate_hz != settings.rate_hz || !sensor.settings.enabled) sensor.next_due_ns = -1;
  sensor.settings = settings;
  return "";
}

void WorldModelTopic::remove(std::size_t robot) { sensors_.erase(robot); }

const WorldModelSettings* WorldModelTopic::settings(std::size_t robot) const {
  const auto it = sensors_.find(robot);
  return it == sensors_.end() ? nullptr : &it->second.settings;
}

bool WorldModelTopic::any_enabled() const {
  for (const auto& [robot, sensor] : sensors_) {
    if (sensor.settings.enabled) return true;
  }
  return false;
}

const WorldSample* WorldModelTopic::sample_at(int64_t time_ns) const {
  // The newest sample at or before `time_ns`; the oldest one kept if all are newer.
  const WorldSample* best = nullptr;
  for (std::size_t i = 0; i < count_; ++i) {
    const WorldSample& s = history_[(next_ + history_.size() - 1 - i) % history_.size()];
    best = &s;
    if (s.sim_time_ns <= time_ns) break;
  }
  return best;
}

void WorldModelTopic::on_sample(const WorldSample& sample,
                                const std::function<void(std::size_t, const proto::truth::WorldModel&)>& emit) {
  history_[next_] = sample;
  next_ = (next_ + 1) % history_.size();
  count_ = std::min(count_ + 1, history_.size());
  const int64_t now = sample.sim_time_ns;
  for (auto& [robot, sensor] : sensors_) {
    if (!sensor.settings.enabled || !sample.robots[robot].present) continue;
    if (sensor.next_due_ns >= 0 && now < sensor.next_due_ns) continue;
    const auto period_ns = static_cast<int64_t>(std::llround(1e9 / sensor.settings.rate_hz));
    sensor.next_due_ns = sensor.next_due_ns < 0 ? now + period_ns : sensor.next_due_ns + period_ns;
    if (sensor.next_due_ns <= now) sensor.next_due_ns = now + period_ns;  // fell behind: no burst
    const WorldSample* seen = sample_at(now - std::llround(sensor.settings.latency_s * 1e9));
    if (seen == nullptr || !seen->robots[robot].present) continue;
    emit(robot, build_world_model(*seen, robot, sensor.settings, field_, sensor.rng, now, ++sensor.sequence));
  }
}

}  // namespace doppel::truth
