#pragma once
// Robots added and removed while doppel runs (contract::RobotHost; docs/robots-at-run-time.md). A
// request is checked whole on the asking thread first (robot file, cameras, placement, team, room);
// a refusal names the request's field and leaves nothing behind. Then the robot is built: its
// cameras' streams (CameraFeed::add), then, on the simulation thread between two ticks, its body in
// the world, its buses' devices and ports (RobotRuntime) and its entries in the simulation control
// (SimController::attach) — that tick may overrun —, then on the asking thread its latency-timer
// files, its bus threads and its cameras. Its runtime, camera names, world-model binding and
// listing come from the RobotBuilder that builds the robots doppel started with (robot_builder.h).
// A step that fails undoes the steps before it. Removal
// runs the same steps backwards. One request at a time (a mutex on the asking side); the
// simulation thread never waits for it.
//
// The robots doppel started with are reported by robots() but cannot be removed; robots added
// here are not recorded (--record) and keep no EEPROM state file (--state-dir).

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "contract/robot_host.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "sim_controller.h"

namespace doppel::bus {
class LinkDirectory;
class LatencyTimerFiles;
}  // namespace doppel::bus

namespace doppel::truth {
class TruthService;
}  // namespace doppel::truth

namespace doppel::gateway {

class CameraFeed;
class RobotRuntime;

// Where robot `robot` stands at kick-off (gateway.cpp): teams alternate, each on its own half.
physics::RobotPlacement kick_off_placement(std::size_t robot);

class LiveRobots final : public contract::RobotHost {
 public:
  // What the gateway owns and the robots added here use; every part outlives this object.
  struct Parts {
    const Options* options = nullptr;
    physics::World* world = nullptr;      // null: doppel runs without physics, every request is refused
    bus::LinkDirectory* links = nullptr;
    CameraFeed* cameras = nullptr;        // null: no camera (--no-camera)
    SimController* controller = nullptr;
    truth::TruthService* truth = nullptr;  // null: no truth transport (--world-model, --sensor-levels), no world model
    double carpet_half_length_m = 0.0;    // where a robot may be placed: |x| and |y| within these
    double carpet_half_width_m = 0.0;
  };
  // `started`: the robots doppel started with, by index (0..n-1), with their links.
  LiveRobots(Parts parts, std::vector<contract::RobotAdded> started);
  ~LiveRobots() override;
  LiveRobots(const LiveRobots&) = delete;
  LiveRobots& operator=(const LiveRobots&) = delete;

  contract::AddResult add_robot(const contract::RobotRequest& request) override;
  std::optional<contract::Refusal> remove_robot(uint32_t robot) override;
  std::vector<contract::RobotAdded> robots() override;

  // The gateway, around its simulation thread: while it runs, the world's part of an add or remove
  // is handed to it; otherwise it runs on the asking thread.
  void simulation_started() noexcept { simulation_running_.store(true, std::memory_order_release); }
  void simulation_stopped() noexcept { simulation_running_.store(false, std::memory_order_release); }
  // Removes every robot added here and refuses later requests. Call while the simulation thread
  // still runs (Gateway::stop does it before it stops that thread).
  void close();

  // Simulation thread, at the start of every tick: carries out a pending add or remove (allocates,
  // may overrun the tick); otherwise one atomic load. Never throws.
  void run_pending() noexcept;
  // Simulation thread, around the world's step: the added robots' drive and sense. rt-safe.
  void drive(double dt_s) noexcept;
  void sense(int64_t sim_time_ns) noexcept;

  std::string summary();

 private:
  struct Live;
  struct Plan;
  // The whole request checked, nothing built: a plan or the refusal.
  std::variant<Plan, contract::Refusal> check(const contract::RobotRequest& request) const;
  // Runs `job` on the simulation thread between two ticks (or here when it does not run) and
  // rethrows what it threw.
  void on_simulation_thread(const std::function<void()>& job);
  // Undoes whatever of `live` was built, in reverse order; never throws.
  void tear_down(Live& live) noexcept;

  Parts parts_;

  std::vector<contract::RobotAdded> started_;
  std::mutex mutex_;    // one add or remove at a time (asking side)
  bool closed_ = false;  // under mutex_
  std::array<std::unique_ptr<Live>, kSimMaxRobots> live_;  // by robot index, under mutex_

  std::atomic<bool> simulation_running_{false};
  std::atomic<const std::function<void()>*> job_{nullptr};
  std::array<RobotRuntime*, kSimMaxRobots> driven_{};  // simulation thread: the added robots' runtimes
};

}  // namespace doppel::gateway
