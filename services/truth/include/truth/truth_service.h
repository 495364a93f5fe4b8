#pragma once
// Ground truth inside doppel: the `doppel-truth` thread publishes every robot's world-model messages
// (world_model.h) through the truth transport (transport.h), and gives other kinds of ground truth
// (sensor levels) the same transport through pollers.
//
// The simulation thread only copies a fixed-size WorldSample into a lock-free queue after each step
// (capture(): no allocation, no lock, no log); the doppel-truth thread drains the queue, keeps the
// history the latency needs, builds the messages that are due and sends them. Robots and settings
// change from any other thread while it runs: robot bindings reach the simulation thread through a
// second queue; settings and the transport are shared by the doppel-truth thread and the callers
// under a mutex the simulation thread never takes.

#include <Eigen/Geometry>

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "concurrency/spsc_queue.h"
#include "contract/world_model_settings.h"
#include "physics/world.h"
#include "truth/transport.h"
#include "truth/world_model.h"

namespace doppel::roudi {
class Host;
}

namespace doppel::truth {

inline constexpr const char kWorldModelTopic[] = "world_model";

// Where robot r is in the physics world and what its field of view follows.
struct RobotBinding {
  std::size_t in_world = 0;  // its index in physics::World
  uint8_t team = 0;          // 0 cyan, 1 magenta
  bool has_camera = false;   // the view follows the head camera's optical axis (camera frame z)
  std::size_t camera_body = 0;                               // the body the camera is mounted on
  Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();    // camera frame in that body's frame
};

struct TruthOptions {
  TransportOptions transport;
  bool verbose = false;  // iceoryx's own log lines, when this service starts RouDi
};

struct TruthStats {
  uint64_t samples = 0;          // world samples taken from the simulation thread
  uint64_t samples_dropped = 0;  // samples the simulation thread could not queue (this thread was behind)
  uint64_t messages = 0;         // world-model messages built
  TransportStats transport;
};

class TruthService {
 public:
  // With transport.iceoryx, shares this process' iceoryx (roudi::Host: the cameras' when they
  // brought it up, else a new one, RouDi inside doppel unless one runs). Throws std::runtime_error /
  // std::invalid_argument naming the problem. Setup.
  explicit TruthService(TruthOptions options);
  ~TruthService();
  TruthService(const TruthService&) = delete;
  TruthService& operator=(const TruthService&) = delete;

  // Robot `robot` (the control API's index) gets a world-model sensor with `settings`. Returns ""
  // or the problem (settings_problem(), naming the field; an index beyond kMaxRobots); nothing
  // changes on a problem. Any thread but the simulation thread, before or after start().
  std::string add_robot(std::size_t robot, const RobotBinding& binding, const contract::WorldModelSettings& settings);
  // Its sensor stops and its services are withdrawn. Any thread but the simulation thread.
  void remove_robot(std::size_t robot);
  std::optional<contract::WorldModelSettings> settings(std::size_t robot);
  // Changes the settings while running: "" or the problem naming the field ("no world-model sensor"
  // for a robot without one).
  std::string set_settings(std::size_t robot, const contract::WorldModelSettings& settings);

  // Another topic on the same transport: `poll` runs on the doppel-truth thread every cycle (about
  // 1 ms) with the transport, to send what its own queue holds. Before start().
  using Poller = std::function<void(Transport&)>;
  void add_poller(Poller poll);

  // Simulation thread, after each step: queues the world as it is now when a sensor is on. rt-safe.
  void capture(const physics::World& world, int64_t sim_time_ns) noexcept;

  void start();
  void stop();  // idempotent; after the simulation thread stopped calling capture()

  TruthStats stats();
  const TransportOptions& transport_options() const noexcept { return options_.transport; }
  std::string describe() const;  // for doppel's start-up lines

 private:
  // A RobotBinding as plain values (the queue's slots must copy without throwing).
  struct BindingChange {
    std::size_t robot = 0;
    bool bound = false;
    std::size_t in_world = 0;
    uint8_t team = 0;
    bool has_camera = false;
    std::size_t camera_body = 0;
    std::array<double, 16> X_BC{};  // column-major 4x4
  };
  void push_change(const BindingChange& change);
  void run() noexcept;
  void update_enabled();  // under mutex_

  TruthOptions options_;
  std::shared_ptr<roudi::Host> roudi_;  // with transport.iceoryx

  // Simulation thread.
  std::array<std::optional<RobotBinding>, kMaxRobots> bindings_{};
  std::unique_ptr<concurrency::SpscQueue<WorldSample, 1024>> samples_;   // sim -> doppel-truth
  std::unique_ptr<concurrency::SpscQueue<BindingChange, 16>> bindings_in_;  // callers -> sim
  std::atomic<bool> any_enabled_{false};

  std::mutex binding_mutex_;  // producer side of bindings_in_ (callers only)
  std::mutex mutex_;          // topic_, transport_, pollers_, messages_: doppel-truth thread and callers
  std::unique_ptr<Transport> transport_;
  WorldModelTopic topic_;
  std::vector<Poller> pollers_;
  uint64_t samples_taken_ = 0, messages_ = 0;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace doppel::truth
