#pragma once
// The scenario on the simulation thread (a gateway::StepObserver): applies the schedule at its
// simulation times and accumulates every robot's metrics. Internal to scenario/ (run.cpp, tests).

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <vector>

#include "gateway/gateway.h"
#include "physics/world.h"
#include "scenario/metrics.h"
#include "scenario/scenario.h"

namespace doppel::scenario {

struct Event {
  int64_t at_ns = 0;  // applied after the first step ending at or after this time
  bool push = true;   // else a ball move
  std::size_t index = 0;
};

// Everything is sized in the constructor; after_step() only reads the world and writes its own
// preallocated state: rt-safe.
class ScenarioObserver final : public gateway::StepObserver {
 public:
  ScenarioObserver(const Scenario& scenario, std::vector<Event> events, int64_t duration_ns,
                   std::vector<std::vector<physics::MotorHandle>> motors)
      : scenario_(scenario), events_(std::move(events)), applied_ns_(events_.size(), -1), duration_ns_(duration_ns),
        motors_(std::move(motors)), tracks_(scenario.robots.size()) {}

  void after_step(physics::World& world, int64_t sim_time_ns) noexcept override {
    if (finished_) return;
    const double dt_s = world.options().step_s;
    if (!started_) {
      started_ = true;
      start_ns_ = sim_time_ns - static_cast<int64_t>(std::llround(dt_s * 1e9));
      for (std::size_t r = 0; r < tracks_.size(); ++r) tracks_[r].start(world.robot_pose(r));
    }
    const int64_t t_ns = sim_time_ns - start_ns_;  // scenario time: 0 when the run began
    for (std::size_t r = 0; r < tracks_.size(); ++r) {
      double power_w = 0.0, drawn_w = 0.0;
      for (const physics::MotorHandle motor : motors_[r]) {
        const physics::MotorState state = world.motor(motor);
        const double p = state.voltage_v * state.supply_current_a;
        power_w += p;
        drawn_w += p > 0.0 ? p : 0.0;
      }
      tracks_[r].step(static_cast<double>(t_ns) * 1e-9, dt_s, world.robot_pose(r), world.tilt_rad(r), power_w, drawn_w);
    }
    ball_ = world.ball_position();
    // Events take effect from the next step on, so an event at t acts from t.
    while (next_ < events_.size() && events_[next_].at_ns <= t_ns) {
      const Event& event = events_[next_];
      if (event.push) {
        const PushEvent& push = scenario_.pushes[event.index];
        world.push(push.robot, Eigen::Vector3d(push.fx_n, push.fy_n, push.fz_n), push.steps);
      } else {
        const BallEvent& ball = scenario_.balls[event.index];
        const double radius = world.options().ball.radius_m;
        world.place_ball(Eigen::Vector3d(ball.x_m, ball.y_m, radius), Eigen::Vector3d(ball.vx_m_s, ball.vy_m_s, 0.0));
      }
      applied_ns_[next_] = t_ns;
      ++next_;
    }
    sim_time_ns_.store(t_ns, std::memory_order_relaxed);
    if (t_ns >= duration_ns_) {
      finished_ = true;
      done_.store(true, std::memory_order_release);
    }
  }

  bool done() const noexcept { return done_.load(std::memory_order_acquire); }
  int64_t sim_time_ns() const noexcept { return sim_time_ns_.load(std::memory_order_relaxed); }
  // Read after the simulation thread stopped (or done()).
  const std::vector<MetricTrack>& tracks() const noexcept { return tracks_; }
  const std::vector<Event>& events() const noexcept { return events_; }
  const std::vector<int64_t>& applied_ns() const noexcept { return applied_ns_; }
  const Eigen::Vector3d& ball() const noexcept { return ball_; }

 private:
  const Scenario& scenario_;
  std::vector<Event> events_;
  std::vector<int64_t> applied_ns_;
  std::size_t next_ = 0;
  int64_t duration_ns_;
  std::vector<std::vector<physics::MotorHandle>> motors_;
  std::vector<MetricTrack> tracks_;
  bool started_ = false, finished_ = false;
  int64_t start_ns_ = 0;
  Eigen::Vector3d ball_ = Eigen::Vector3d::Zero();
  std::atomic<int64_t> sim_time_ns_{0};
  std::atomic<bool> done_{false};
};

// The schedule in time order, each entry rounded up to a whole step: time spreads drawn from `seed`
// (pushes first, then ball moves, each in file order), so the same seed gives the same times.
std::vector<Event> schedule(const Scenario& scenario, uint64_t seed);

}  // namespace doppel::scenario
