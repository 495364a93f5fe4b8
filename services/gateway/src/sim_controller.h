#pragma once
// Simulation control inside doppel (the contract's facets, contract/host.h): requests from the HTTP
// API's threads cross to the simulation thread through a lock-free queue and are applied there between two
// steps; the simulation thread publishes the state every 10 ms through a snapshot. The request side
// takes a mutex (HTTP threads only: one request in flight, the next waits); the simulation thread
// never waits for anyone.

#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "camera/camera_config.h"
#include "camera/renderer.h"
#include "concurrency/snapshot.h"
#include "concurrency/spsc_queue.h"
#include "contract/host.h"
#include "gateway/robot_config.h"
#include "physics/scene_view.h"
#include "physics/world.h"

namespace doppel::truth {
class TruthService;
}

namespace doppel::gateway {

class RobotRuntime;
class FieldServices;
class FaultBoard;

inline constexpr std::size_t kSimMaxRobots = physics::kMaxRobotGroups;
inline constexpr std::size_t kSimMaxJoints = 64;
inline constexpr std::size_t kSimMaxImus = 4;     // per robot
inline constexpr std::size_t kSimMaxFeet = 8;     // foot boards per robot
inline constexpr std::size_t kSimMaxCameras = 4;  // per robot

// A request on its way to the simulation thread, and the state it publishes (SimController).
enum class SimRequestKind : uint8_t { kPause, kResume, kStep, kReset, kPlace, kPush, kBall };
struct SimRequest {
  SimRequestKind kind = SimRequestKind::kPause;
  uint64_t sequence = 0;
  std::size_t robot = 0;
  double a = 0.0, b = 0.0, c = 0.0;
  uint32_t steps = 0;
};
struct SimRobotSample {
  double x = 0.0, y = 0.0, z = 0.0, yaw = 0.0, tilt = 0.0;
  bool held = false;
  std::array<double, kSimMaxJoints> joints{};
  struct Imu {
    double roll = 0.0, pitch = 0.0;
    std::array<double, 3> gyro{};
  };
  std::array<Imu, kSimMaxImus> imus{};
  std::array<std::array<double, 4>, kSimMaxFeet> feet{};
  struct Camera {
    std::array<double, 3> p{};
    std::array<double, 4> q{0.0, 0.0, 0.0, 1.0};
  };
  std::array<Camera, kSimMaxCameras> cameras{};
};
struct SimSample {
  int64_t sim_time_ns = 0;
  bool paused = false;
  uint64_t steps_left = 0;
  uint64_t missed_ticks = 0;
  std::array<SimRobotSample, kSimMaxRobots> robots{};
  std::array<double, 3> ball{};
};

class SimController final : public contract::Simulation,
                            public contract::WorldModel,
                            public contract::Game,
                            public contract::Teamcomm,
                            public contract::Faults {
 public:
  static constexpr std::size_t kMaxRobots = kSimMaxRobots;
  static constexpr std::size_t kMaxJoints = kSimMaxJoints;
  static constexpr int kPublishEveryTicks = 10;  // 100 Hz state
  static constexpr int kSceneEveryTicks = 34;    // the viewer's scene: at most 30 Hz

  // One robot: its runtime, its index in `world` (none without a body) and its name.
  struct Robot {
    RobotRuntime* runtime = nullptr;
    std::optional<std::size_t> in_world;
    std::string name;
    const RobotConfig* config = nullptr;  // its file (devices, cameras; outlives the controller); null: the runtime's
  };
  // `world` may be null (no robot has a body); it and the runtimes outlive the controller. Setup.
  SimController(physics::World* world, std::vector<Robot> robots, double carpet_half_length_m, double carpet_half_width_m);
  ~SimController() override;

  // A robot added while doppel runs (docs/robots-at-run-time.md), as robot `index` (a slot that
  // holds none). attach() on the simulation thread, between two ticks, once the robot is in the
  // world: finds its devices (allocates; throws std::invalid_argument like the constructor) and
  // from then on publishes it. show() on the adding thread afterwards: the HTTP side (state,
  // buses, camera stills) shows it. Removal in the other order: hide() on the removing thread,
  // then detach() on the simulation thread.
  void attach(std::size_t index, Robot robot);
  void show(std::size_t index);
  void hide(std::size_t index);
  void detach(std::size_t index) noexcept;

  // contract::Simulation, from any thread but the simulation thread.
  contract::SimState state() override;
  contract::Outcome pause() override;
  contract::Outcome resume() override;
  contract::Outcome step(uint32_t steps) override;
  contract::Outcome reset() override;
  contract::Outcome place(std::size_t robot, double x_m, double y_m, double yaw_rad) override;
  contract::Outcome push(std::size_t robot, double fx_n, double fy_n, double fz_n, uint32_t steps) override;
  contract::Outcome ball(double x_m, double y_m) override;
  contract::Scene scene() override;
  std::vector<contract::BusTable> buses() override;
  // Renders the camera's view of the newest published scene on the calling (HTTP) thread, at most
  // once per kStillPeriod per camera (the same still otherwise), and encodes it as PNG.
  contract::Result<contract::CameraStill> camera_still(const std::string& name) override;
  static constexpr std::chrono::milliseconds kStillPeriod{250};
  // The world-model sensors (truth/), served by world_model() and set_world_model(); null: none
  // (facets() then offers no world model). Setup, before the control API starts.
  void set_world_model(truth::TruthService* truth) noexcept { truth_ = truth; }
  contract::Result<contract::WorldModelSettings> world_model(std::size_t robot) override;
  contract::Result<contract::WorldModelSettings> set_world_model(std::size_t robot,
                                                                 const contract::WorldModelSettings& settings) override;
  // The GameController and the hub (field_services.h) answer the game and teamcomm requests;
  // `field` outlives the controller; null: facets() offers neither. Setup, before the API serves.
  void set_field_services(FieldServices* field) noexcept { field_ = field; }
  contract::GameStatus game() override;
  contract::Outcome game_command(const contract::GameCommand& command) override;
  std::optional<contract::TeamcommStatus> teamcomm() override;
  contract::Outcome teamcomm_add(const contract::TeamcommRobot& robot) override;
  contract::Outcome teamcomm_remove(int team, int player) override;
  // Faults on demand (fault_board.h); `board` outlives the controller; null: facets() offers none.
  // Setup, before the API serves.
  void set_fault_board(FaultBoard* board) noexcept { faults_ = board; }
  contract::FaultList faults() override;
  contract::Result<uint32_t> add_fault(const faults::FaultSpec& spec) override;
  contract::Outcome clear_fault(uint32_t number) override;
  contract::Outcome clear_faults() override;
  // What the control API serves: the simulation, and each facet whose service was set above.
  contract::Facets facets() noexcept;
  // Every state published from now on, queued for one reader (the recorder, `--record`): the
  // snapshot behind state() holds only the newest, and a reader kept off the CPU for longer than
  // one publishing period would miss states. Setup, before the simulation thread runs; allocates
  // the queue (kKeptStates states, 2.56 s of simulation) once. The queue lives as long as this.
  contract::StateQueue* keep_published_states();
  static constexpr std::size_t kKeptStates = 256;

  // Simulation thread, at the start of every tick: applies the requests that arrived. True when the
  // world advances in this tick (not paused, or a step is running). rt-safe.
  bool begin_tick() noexcept;
  // Simulation thread, at the end of every tick: publishes the state every kPublishEveryTicks
  // (with the 1 ms ticks the thread missed so far), the scene every kSceneEveryTicks. rt-safe.
  void end_tick(int64_t sim_time_ns, uint64_t missed_ticks = 0) noexcept;

 private:
  // Queues `request` and waits until the simulation thread has carried it out (or `timeout`).
  using Kind = SimRequestKind;
  using Request = SimRequest;
  using RobotSample = SimRobotSample;
  using Sample = SimSample;

  // Where camera i of robot r is now. Simulation thread; rt-safe.
  Eigen::Isometry3d camera_pose(std::size_t r, std::size_t i) const noexcept;
  // Setup: finds robot r's links, IMUs, foot boards (by its file's devices) and cameras in the world.
  void add_devices(std::size_t r);
  contract::Outcome submit(Request request, std::chrono::milliseconds timeout);
  void apply(const Request& request) noexcept;
  void finish(uint64_t sequence, bool refused) noexcept;
  // Fills and publishes the state sample (simulation thread, or the constructor before it runs).
  void publish_sample(int64_t sim_time_ns, uint64_t missed_ticks) noexcept;
  // A published sample as the contract shows it (robot names, sensors); request side.
  contract::SimState state_of(const Sample& sample);
  class KeptStates;

  physics::World* world_;
  FieldServices* field_ = nullptr;
  FaultBoard* faults_ = nullptr;
  truth::TruthService* truth_ = nullptr;
  // Per robot index (kMaxRobots slots; an index without a robot has runtime null). An entry is
  // written only while neither side shows it: present_ (simulation thread) and shown_ (under
  // robots_mutex_, the HTTP threads) say which entries are in use.
  std::vector<Robot> robots_;
  std::array<bool, kSimMaxRobots> present_{};  // simulation thread
  std::mutex robots_mutex_;                     // request side only
  std::array<bool, kSimMaxRobots> shown_{};     // under robots_mutex_
  std::vector<std::vector<std::string>> joint_names_;  // per robot, its figure's links (none without a body)
  // Per robot (in the world): its IMUs, foot boards and cameras, found at setup.
  template <typename Handle>
  struct Sensor {
    std::string name;
    uint32_t bus = 0;
    uint8_t id = 0;
    Handle handle;
  };
  struct Camera {
    std::string name;
    std::size_t body = 0;
    camera::CameraConfig config;  // its file's lens, size, noise and mount
    std::array<std::array<double, 3>, 4> corner_rays{};
  };
  std::vector<std::vector<Sensor<physics::ImuHandle>>> imus_;
  std::vector<std::vector<Sensor<physics::FootHandle>>> feet_;
  std::vector<std::vector<Camera>> cameras_;
  double carpet_half_length_m_, carpet_half_width_m_;

  std::mutex submit_mutex_;  // request side only
  uint64_t next_sequence_ = 0;
  concurrency::SpscQueue<Request, 4> requests_;
  std::atomic<uint64_t> finished_{0};  // sequence of the last request carried out
  std::atomic<bool> finished_refused_{false};  // the last request carried out was refused (step while running)

  std::mutex read_mutex_;  // request side only: the snapshot has one reader
  concurrency::Snapshot<Sample> samples_;
  std::unique_ptr<KeptStates> kept_;  // null unless keep_published_states() was called
  // Every visible shape, published every kSceneEveryTicks. Every slot is sized at setup
  // (World::fill_scene), so publishing allocates nothing.
  // The scene and where every robot camera was when it was taken (for camera_still()).
  struct ScenePublication {
    physics::SceneView view;
    std::array<std::array<Eigen::Isometry3d, kSimMaxCameras>, kSimMaxRobots> X_WC;
  };
  std::mutex scene_mutex_;  // request side only
  std::unique_ptr<concurrency::Snapshot<ScenePublication>> scene_;  // null without a world
  // Camera stills (HTTP threads only, under stills_mutex_): per camera (cameras_ flattened), a
  // renderer made on first use and the last PNG with its wall-clock time.
  struct Still {
    std::size_t robot = 0, camera = 0;
    std::unique_ptr<camera::Renderer> renderer;
    std::vector<uint8_t> rgb;
    std::string png;
    double sim_time_s = -1.0;
    std::chrono::steady_clock::time_point taken{};
  };
  std::mutex stills_mutex_;
  std::vector<Still> stills_;

  // Simulation thread.
  bool paused_ = false;
  uint64_t steps_left_ = 0;
  uint64_t step_sequence_ = 0;  // the step request to finish when steps_left_ reaches 0
  uint64_t pending_sequence_ = 0;  // a request applied in this tick, answered once its state is out
  bool pending_refused_ = false;
  bool advancing_ = true;       // the world advances in this tick
  int ticks_ = 0;
  int scene_ticks_ = 0;
};

}  // namespace doppel::gateway
