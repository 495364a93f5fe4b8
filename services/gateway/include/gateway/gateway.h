#pragma once
// The running double of one or more robots: for every bus a pseudo-terminal with its devices and
// an I/O thread, and one simulation thread at 1 kHz that runs the servos' motor controllers, steps
// the physics world of the robots' bodies and produces the sensor readings, and around them the
// cameras, the world model, the recorder, the control API, the field services and the session
// handshake. Each is a component in one ordered list (lifecycle.h): the constructor configures them
// (loads robots, builds the devices, opens the ports and links: everything that allocates or may
// fail), start() starts their threads, stop() joins them. The bus threads never wait for the
// simulation: commands and feedback cross between them as lock-free snapshots.

#include <atomic>
#include <cstdint>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "contract/faults.h"
#include "contract/robot_host.h"
#include "gateway/lifecycle.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"

namespace doppel::physics {
class World;
}
namespace doppel::lockstep {
class Coordinator;
}
namespace doppel {
class Fnv1a;
}

namespace doppel::control {
class HttpApi;
}
namespace doppel::contract {
class TokenFile;
}
namespace doppel::record {
class Recorder;
}
namespace doppel::truth {
class TruthService;
}
namespace doppel::bus {
class LinkDirectory;
class LatencyTimerFiles;
}

namespace doppel::teamcomm {
class Hub;
}
namespace doppel::handshake {
class Server;
}

namespace doppel::gateway {

class RobotRuntime;
class FieldServices;
class CameraFeed;
class SimController;
class LiveRobots;
class SensorLevelsFeed;
class FaultBoard;

// Watches (and may act on) the world from the simulation thread after every step that advanced
// it: a scenario run's schedule and metrics (scenario/). Implementations must be rt-safe: no
// allocation, lock or log.
class StepObserver {
 public:
  virtual ~StepObserver() = default;
  // `sim_time_ns`: the world's time after the step; robot r of the gateway is world robot r when
  // every robot has a body (Gateway::world_index says so for each).
  virtual void after_step(physics::World& world, int64_t sim_time_ns) noexcept = 0;
};

class Gateway {
 public:
  // Configures every robot of `options`. Throws (std::invalid_argument, std::runtime_error) with a
  // message for the user when a robot file or a port cannot be set up.
  explicit Gateway(const Options& options);
  // The same with the robots (in the order of options.buses.robots) and the session already loaded, so
  // that a caller can tell reading files (no side effects) from opening ports and links. `hook`
  // sees every component's transitions (lifecycle.h; tests inject failures with it).
  Gateway(const Options& options, std::vector<RobotConfig> configs, const SessionConfig& session, TransitionHook hook = {});
  ~Gateway();
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  // Starts every component in list order (components()): the bus and simulation threads, the
  // servers, the session handshake. When one fails, those started stop in reverse order and the
  // error is thrown. Once.
  void start();
  // Stops the started components in reverse order, saving every robot's EEPROM state; idempotent.
  void stop();
  // The components in the order they configure and start (they stop and release in reverse).
  std::vector<std::string> components() const { return lifecycle_.names(); }

  // Adds and removes robots while doppel runs (contract/robot_host.h; docs/robots-at-run-time.md).
  // Any thread; valid for the gateway's lifetime.
  contract::RobotHost& robot_host() noexcept;

  std::string describe() const;  // the links and the devices behind them, for the user
  uint16_t control_port() const noexcept;  // where simulation control is served; 0 = not served
  std::string summary() const;   // per-bus counters, for the user after stop()
  // The team-communication hub (--teamcomm), for whoever registers robots while doppel runs (the
  // session handshake): Hub::add_robot and remove_robot are thread-safe. Null without --teamcomm.
  teamcomm::Hub* teamcomm_hub() noexcept;

  // Lockstep (options.lockstep.enabled, docs/lockstep.md): `callback` gets the run hash of every simulated
  // second (1, 2, ...) on the simulation thread, right after the physics step at its end; it must
  // be quick and must not call back into the gateway. Set before start(); replaces --hashes output.
  using HashCallback = std::function<void(int64_t second, uint64_t hash)>;
  void on_second_hash(HashCallback callback);
  // Simulation time, ns (lockstep or not: the world's, or the simulation thread's count). Any thread.
  int64_t sim_time_ns() const noexcept { return sim_time_ns_.load(std::memory_order_relaxed); }
  // The lockstep clock file controllers are started with (doppel-run --lockstep); "" without --lockstep.
  std::string lockstep_clock_path() const;
  // Before start(): `observer` (outlives the gateway's threads) sees every step. Null: none.
  void set_step_observer(StepObserver* observer) noexcept { step_observer_ = observer; }
  // Faults on demand (docs/faults.md), as /api/faults adds them: a scenario adds its faults here
  // before start(). Any thread.
  contract::Result<uint32_t> add_fault(const faults::FaultSpec& spec);
  // Robot r's index in the physics world; nullopt when it moves kinematically.
  std::optional<std::size_t> world_index(std::size_t robot) const;
  // The physics world (setup: look-ups such as find_motor); null when no robot has a body.
  const physics::World* world() const noexcept { return world_.get(); }

  // The run's access token for the HTTP API and the TCP handshake ("" with --no-token).
  const std::string& access_token() const noexcept { return access_token_; }

  // Writes each robot's state file now (bus threads stopped, or from the published snapshots when
  // `published`). Returns false and reports on `std::cerr` when a file cannot be written.
  bool save_state(bool published);

 private:
  // The components, in order (gateway.cpp says why each stands where it does).
  void add_components();
  void configure_world();
  void configure_state();
  void configure_robots();
  void configure_lockstep();  // --lockstep; throws
  void configure_truth();     // --world-model, --sensor-levels; throws
  void configure_cameras();
  void configure_recorder();  // --record: opens the file; throws
  void configure_control();   // the HTTP API (and the viewer's page); throws for a port the user named
  void configure_live_robots();
  void start_handshake();     // the session handshake and its token file; throws for a named port
  void simulate() noexcept;
  void simulate_lockstep() noexcept;  // simulate() on the lockstep clock (docs/lockstep.md)
  // One simulation tick (1 ms): drives, steps, senses. Simulation thread; rt-safe.
  void step_world(int64_t& sim_time_ns) noexcept;
  void keep_state() noexcept;  // the state thread: saves a robot's EEPROM shortly after it changed
  // Writes the token for a TCP listener on `port` to LINK_DIR/token-PORT (0600; removed with the
  // returned file); null with --no-token. Throws std::runtime_error naming the file.
  std::unique_ptr<contract::TokenFile> publish_token(uint16_t port) const;

  Options options_;
  SessionConfig session_;
  std::vector<RobotConfig> configs_;
  std::string access_token_;  // contract/access_token.h; "" with --no-token
  std::unique_ptr<bus::LinkDirectory> links_;
  std::unique_ptr<physics::World> world_;  // the bodies of every robot that has one; null if none
  std::vector<std::optional<std::size_t>> in_world_;  // per robot: its index in world_
  std::vector<std::string> state_files_;  // per robot; empty without a state directory
  std::atomic<bool> state_stop_{false};
  std::thread state_thread_;
  std::vector<std::unique_ptr<RobotRuntime>> robots_;
  std::unique_ptr<bus::LatencyTimerFiles> latency_files_;
  std::unique_ptr<lockstep::Coordinator> lockstep_;  // --lockstep
  std::vector<std::unique_ptr<Fnv1a>> bus_hashes_;   // --lockstep: per bus (robot order), folded by its server
  HashCallback hash_callback_;
  std::ofstream hashes_file_;
  std::unique_ptr<SimController> controller_;   // pause, step, reset, place, push (simulation thread)
  std::unique_ptr<FaultBoard> faults_;          // every fault of the run; sets the buses' fault tables
  std::unique_ptr<truth::TruthService> truth_;  // --world-model, --sensor-levels
  std::unique_ptr<SensorLevelsFeed> levels_feed_;  // --sensor-levels: a poller of truth_
  std::unique_ptr<CameraFeed> cameras_;   // cameras of the simulated robots; null with --no-camera
  std::unique_ptr<record::Recorder> recorder_;  // --record; reads controller_ and the buses' taps
  std::unique_ptr<FieldServices> field_;        // the GameController and the team-communication hub
  std::atomic<bool> simulation_stop_{false};
  std::thread simulation_thread_;
  uint64_t missed_ticks_ = 0;
  std::atomic<int64_t> sim_time_ns_{0};
  StepObserver* step_observer_ = nullptr;
  std::unique_ptr<LiveRobots> live_;  // robots added while running
  std::unique_ptr<control::HttpApi> control_api_;  // serves controller_; null with --no-viewer
  std::unique_ptr<contract::TokenFile> control_token_;
  bool viewer_page_ = false;  // control_api_ serves the viewer's page too
  std::atomic<bool> bus_stop_{false};  // tells the bus threads to stop
  std::unique_ptr<handshake::Server> handshake_;  // --no-handshake: null
  std::unique_ptr<contract::TokenFile> handshake_token_;
  Lifecycle lifecycle_;  // last: released (in its own order) before any member above goes
};

// The robots of `options`, loaded in order (robot names looked up in robots_dir or the default).
std::vector<RobotConfig> load_robots(const Options& options);

// Link path of bus `bus` of robot `robot` under `link_dir` (README: ttyDXL<b>, robot<r>/ttyDXL<b>).
std::string link_path(const std::string& link_dir, std::size_t robot, std::size_t bus);

}  // namespace doppel::gateway
