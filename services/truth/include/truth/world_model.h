#pragma once
// The world-model virtual sensor (thesis 4.2.1.5): from a sample of the world, the message a robot
// gets: its own pose, the balls, goal posts, side poles, field landmarks and the other robots, each
// in the field frame and relative to the robot, limited by a field of view, a range and "nearest
// ball only", and degraded by Gaussian noise, dropout and latency (contract::WorldModelSettings).
//
// Pure computation, no threads: WorldSample is what the simulation thread captures (fixed size,
// copied through a queue); WorldModelTopic keeps a history of samples for latency, decides which
// robot's message is due at its rate and builds it. The publisher thread (world_model_service.h)
// runs it; tests run it directly.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "contract/world_model_settings.h"
#include "physics/field.h"
#include "proto/truth.pb.h"

namespace doppel::truth {

inline constexpr std::size_t kMaxRobots = 6;  // physics::kMaxRobotGroups
inline constexpr std::size_t kMaxBalls = 8;   // the ball and physics::kMaxExtraBalls

// One robot at one instant. The view is where its field of view starts and points: the head
// camera's position and optical axis projected onto the floor, or the robot's pose without a camera
// (or while the camera looks straight down).
struct RobotSample {
  bool present = false;
  uint8_t team = 0;
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;                // robot frame in the field frame
  double view_x_m = 0.0, view_y_m = 0.0, view_yaw_rad = 0.0;  // field of view: apex and centre line
};

// The world at one instant: fixed size, no pointers (it crosses threads by copy).
struct WorldSample {
  int64_t sim_time_ns = 0;
  std::array<RobotSample, kMaxRobots> robots{};
  uint32_t ball_count = 0;
  std::array<std::array<double, 3>, kMaxBalls> balls{};  // centres, field frame
};

// "" when `settings` can be used, else what is wrong, naming the field
// ("fov_deg must be 0 (all around) or within (0, 180), got 200").
std::string settings_problem(const contract::WorldModelSettings& settings);

// The static objects of the field, from physics/field.h (field_shapes() and field_features()).
struct FieldObjects {
  struct Post {
    proto::truth::GoalPost::Goal goal = proto::truth::GoalPost::YELLOW;
    bool left = false;
    double x_m = 0.0, y_m = 0.0;
  };
  struct Pole {
    bool left = false;
    double x_m = 0.0, y_m = 0.0;
  };
  struct Mark {
    proto::truth::Landmark::Type type = proto::truth::Landmark::L_CROSSING;
    double x_m = 0.0, y_m = 0.0, heading_rad = 0.0;
  };
  std::vector<Post> posts;  // 4
  std::vector<Pole> poles;  // 2
  std::vector<Mark> marks;  // 8 L, 6 T, 2 X, 2 penalty marks, the centre circle
};
FieldObjects field_objects(const physics::FieldSpec& spec = {});

// (x, y) of a field point in the frame of a robot at (x, y, yaw), with distance and bearing.
proto::truth::Relative relative_to(double robot_x_m, double robot_y_m, double robot_yaw_rad, double x_m, double y_m);

// True when a point at (x, y) lies in the view of `robot` under `settings` (field of view and range).
bool in_view(const RobotSample& robot, const contract::WorldModelSettings& settings, double x_m, double y_m);

// Robot `robot`'s message from `sample` (the world `settings.latency_s` ago) at `sim_time_ns`. `rng`
// draws the noise and the dropout (per robot, seeded from settings.seed). `robot` must be present.
proto::truth::WorldModel build_world_model(const WorldSample& sample, std::size_t robot,
                                           const contract::WorldModelSettings& settings, const FieldObjects& field,
                                           std::mt19937_64& rng, int64_t sim_time_ns, uint64_t sequence);

// The schedule and the history: which robot's message is due at each new sample, from which past
// sample. One thread.
class WorldModelTopic {
 public:
  // History of the last `history_s` seconds of samples (latency may not exceed it).
  explicit WorldModelTopic(const physics::FieldSpec& spec = {}, double history_s = 1.1);

  // Adds (or replaces) robot `robot`'s sensor. Returns settings_problem(); nothing changes on a problem.
  std::string set(std::size_t robot, const contract::WorldModelSettings& settings);
  void remove(std::size_t robot);
  // Settings of robot `robot`, or nullptr when it has no sensor.
  const contract::WorldModelSettings* settings(std::size_t robot) const;
  bool any_enabled() const;

  // The next sample (sim_time_ns increasing). For every enabled robot whose message is due
  // (every 1/rate_hz of simulation time) calls `emit(robot, message)`.
  void on_sample(const WorldSample& sample,
                 const std::function<void(std::size_t, const proto::truth::WorldModel&)>& emit);

 private:
  struct Sensor {
    contract::WorldModelSettings settings;
    std::mt19937_64 rng;
    int64_t next_due_ns = -1;  // -1: at the next sample
    uint64_t sequence = 0;
  };
  const WorldSample* sample_at(int64_t time_ns) const;

  FieldObjects field_;
  std::map<std::size_t, Sensor> sensors_;
  std::vector<WorldSample> history_;  // ring
  std::size_t next_ = 0, count_ = 0;
};

}  // namespace doppel::truth
