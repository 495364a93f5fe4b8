#include "gateway/gateway.h"

#include <pthread.h>
#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <climits>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>

#include "bus/latency_timer_files.h"
#include "bus/link_directory.h"
#include "camera_feed.h"
#include "gateway/fixed_rate_clock.h"
#include "physics/carpet.h"
#include "physics/engines.h"
#include "physics/field.h"
#include "physics/world.h"
#include "eeprom_state.h"
#include "field_services.h"
#include "contract/access_token.h"
#include "control/http_api.h"
#include "base/fnv_hash.h"
#include "base/monotonic_clock.h"
#include "lockstep/coordinator.h"
#include "record/recorder.h"
#include "fault_board.h"
#include "live_robots.h"
#include "robot_runtime.h"
#include "sim_controller.h"
#include "truth/truth_service.h"
#include "handshake/server.h"
#include "gateway/handshake_service.h"
#include "robot_builder.h"
#include "sensor_levels_feed.h"

namespace doppel::gateway {

inline constexpr int64_t kSimulationStepNs = 1'000'000;  // 1 kHz

std::string link_path(const std::string& link_dir, std::size_t robot, std::size_t bus) {
  std::string name = "ttyDXL" + std::to_string(bus);
  return robot == 0 ? link_dir + "/" + name : link_dir + "/robot" + std::to_string(robot) + "/" + name;
}

// Where robot r stands at kick-off: teams alternate, each on its own half, facing the centre.
physics::RobotPlacement kick_off_placement(std::size_t r) {
  physics::RobotPlacement placement;
  const bool second_team = r % 2 == 1;
  const double row = static_cast<double>(r / 2);
  placement.position_m = Eigen::Vector3d(second_team ? 1.0 + 0.5 * row : -1.0 - 0.5 * row, -0.8 + 0.8 * row, 0.0);
  placement.yaw_rad = second_team ? std::numbers::pi : 0.0;
  placement.team = second_team ? 1 : 0;
  return placement;
}

namespace {

// Where robot r starts: where the options put it (a scenario's start pose), else its kick-off spot.
physics::RobotPlacement start_placement(const Options& options, std::size_t r) {
  return r < options.world.placements.size() && options.world.placements[r] ? *options.world.placements[r] : kick_off_placement(r);
}

}  // namespace

std::vector<RobotConfig> load_robots(const Options& options) {
  const std::string robots_dir = options.buses.robots_dir.empty() ? default_robots_dir() : options.buses.robots_dir;
  std::vector<RobotConfig> configs;
  for (const std::string& robot : options.buses.robots) {
    configs.push_back(load_robot(robot, robots_dir));
  }
  return configs;
}

Gateway::Gateway(const Options& options)
    : Gateway(options, load_robots(options),
              options.world.session.empty() ? SessionConfig{} : load_session(options.world.session)) {}

Gateway::Gateway(const Options& options, std::vector<RobotConfig> configs, const SessionConfig& session, TransitionHook hook)
    : options_(options), session_(session), configs_(std::move(configs)), lifecycle_(std::move(hook)) {
  if (options.viewer.token) {
    access_token_ = contract::new_access_token();
  } else if (options.viewer.enabled || (options.handshake.enabled && options.handshake.tcp)) {
    std::cerr << "doppel: warning: --no-token: every local user and program can use the control API and the TCP "
                 "handshake (docs/security.md)\n";
  }
  add_components();
  lifecycle_.configure();
}

void Gateway::add_components() {
  // The order is the one place that says what needs what: a component may use every one above it
  // from configure until release, and stops before any of them.
  lifecycle_.add({"links", [this] {
                    try {
                      links_ = std::make_unique<bus::LinkDirectory>(options_.buses.link_dir, options_.buses.allow_shared_link_dir, std::cerr);
                      for (std::size_t r = 1; r < configs_.size(); ++r) links_->subdirectory("robot" + std::to_string(r));
                    } catch (const bus::UnsafeLinkDirectory& e) {
                      throw std::runtime_error(std::string(e.what()) + " (--allow-shared-link-dir uses it anyway)");
                    }
                  },
                  {}, {}, [this] { links_.reset(); }});
  lifecycle_.add({"world", [this] { configure_world(); }, {}, {}, [this] { world_.reset(); }});
  // The state thread saves what the bus threads change, so it stops (and saves last) after them.
  lifecycle_.add({"state", [this] { configure_state(); },
                  [this] {
                    if (state_files_.empty()) return;
                    state_stop_ = false;
                    state_thread_ = std::thread([this] {
                      pthread_setname_np(pthread_self(), "doppel-state");
                      keep_state();
                    });
                  },
                  [this] {
                    state_stop_ = true;
                    if (state_thread_.joinable()) state_thread_.join();
                    if (!state_files_.empty()) save_state(false);
                  },
                  [this] { state_files_.clear(); }});
  // Ports open here; their links appear only once the buses are served ("buses", below).
  lifecycle_.add({"robots", [this] { configure_robots(); }, {}, {}, [this] { robots_.clear(); }});
  lifecycle_.add({"latency timer files",
                  [this] {
                    latency_files_ = std::make_unique<bus::LatencyTimerFiles>(std::cerr);
                    for (auto& robot : robots_) robot->add_latency_timer_files(*latency_files_);
                  },
                  [this] { latency_files_->start(); }, [this] { latency_files_->stop(); },
                  [this] { latency_files_.reset(); }});
  lifecycle_.add({"lockstep clock", [this] { configure_lockstep(); }, {}, {},
                  [this] {
                    lockstep_.reset();
                    bus_hashes_.clear();
                    hashes_file_.close();
                  }});
  lifecycle_.add({"simulation control",
                  [this] {
                    std::vector<SimController::Robot> controlled;
                    for (std::size_t r = 0; r < configs_.size(); ++r) {
                      controlled.push_back({robots_[r].get(), world_ != nullptr ? in_world_[r] : std::nullopt, configs_[r].name, nullptr});
                    }
                    const physics::FieldSpec field;
                    controller_ = std::make_unique<SimController>(world_.get(), std::move(controlled),
                                                                  physics::carpet_half_length_m(field),
                                                                  physics::carpet_half_width_m(field));
                  },
                  {}, {}, [this] { controller_.reset(); }});
  lifecycle_.add({"faults",
                  [this] {
                    std::vector<RobotRuntime*> faulty;
                    for (auto& robot : robots_) faulty.push_back(robot.get());
                    faults_ = std::make_unique<FaultBoard>(std::move(faulty), sim_time_ns_);
                    controller_->set_fault_board(faults_.get());
                  },
                  {}, {},
                  [this] {
                    controller_->set_fault_board(nullptr);
                    faults_.reset();
                  }});
  // Cameras, truth and recorder take what the simulation thread hands them: they start before it
  // and stop after it (the recorder also after the bus threads, so every tapped event is in the
  // file). Truth hosts iceoryx itself only when no camera does (one host per process): after them.
  lifecycle_.add({"cameras", [this] { configure_cameras(); },
                  [this] {
                    if (cameras_ != nullptr) cameras_->start();
                  },
                  [this] {
                    if (cameras_ != nullptr) cameras_->stop();
                  },
                  [this] { cameras_.reset(); }});
  lifecycle_.add({"truth", [this] { configure_truth(); },
                  [this] {
                    if (truth_ != nullptr) truth_->start();
                  },
                  [this] {
                    if (truth_ != nullptr) truth_->stop();
                  },
                  [this] {
                    controller_->set_world_model(nullptr);
                    levels_feed_.reset();
                    truth_.reset();
                  }});
  lifecycle_.add({"recorder", [this] { configure_recorder(); },
                  [this] {
                    if (recorder_ != nullptr) recorder_->start();
                  },
                  [this] {
                    if (recorder_ != nullptr) recorder_->stop();
                  },
                  [this] { recorder_.reset(); }});
  lifecycle_.add({"simulation", {},
                  [this] {
                    simulation_stop_ = false;
                    simulation_thread_ = std::thread([this] {
                      if (lockstep_ != nullptr) {
                        simulate_lockstep();
                      } else {
                        simulate();
                      }
                    });
                    pthread_setname_np(simulation_thread_.native_handle(), "doppel-sim");  // named before any link appears
                  },
                  [this] {
                    simulation_stop_ = true;
                    if (simulation_thread_.joinable()) simulation_thread_.join();
                  },
                  {}});
  // Neither runs on the simulation thread; the control API serves their state and commands.
  lifecycle_.add({"field services",
                  [this] {
                    field_ = std::make_unique<FieldServices>(options_);
                    controller_->set_field_services(field_.get());
                  },
                  [this] { field_->start(); }, [this] { field_->stop(); },
                  [this] {
                    controller_->set_field_services(nullptr);
                    field_.reset();
                  }});
  // Robots added while running are built on the simulation thread, and go while it still runs.
  lifecycle_.add({"robots added at run time", [this] { configure_live_robots(); },
                  [this] { live_->simulation_started(); },
                  [this] {
                    live_->close();
                    live_->simulation_stopped();
                  },
                  [this] { live_.reset(); }});
  // No request waits for a simulation thread that is gone: the API stops before it.
  lifecycle_.add({"control API", [this] { configure_control(); },
                  [this] {
                    if (control_api_ != nullptr) control_api_->start();
                  },
                  [this] {
                    if (control_api_ != nullptr) control_api_->stop();
                  },
                  [this] {
                    control_token_.reset();
                    control_api_.reset();
                  }});
  // A port's link appears only once its bus is served, after every other start-up step.
  lifecycle_.add({"buses", {},
                  [this] {
                    bus_stop_ = false;
                    for (auto& robot : robots_) {
                      if (lockstep_ == nullptr) {
                        robot->start(bus_stop_, options_.buses.rt_priority);
                      } else {
                        robot->publish_links();  // under lockstep the simulation thread serves the buses itself
                      }
                    }
                  },
                  [this] {
                    bus_stop_ = true;
                    for (auto& robot : robots_) robot->join();
                  },
                  {}});
  // Control software asks for robots once everything they use runs; its requests end first.
  lifecycle_.add({"handshake", {}, [this] { start_handshake(); },
                  [this] {
                    handshake_.reset();
                    handshake_token_.reset();
                  },
                  {}});
}

void Gateway::configure_world() {
  // One world holds the bodies of every robot that has one.
  std::vector<physics::RobotModel> bodies;
  std::vector<physics::RobotPlacement> placements;
  in_world_.assign(configs_.size(), std::nullopt);
  if (options_.world.physics) {
    for (std::size_t r = 0; r < configs_.size(); ++r) {
      if (configs_[r].body) {
        in_world_[r] = bodies.size();
        bodies.push_back(*configs_[r].body);
        placements.push_back(start_placement(options_, r));
      }
    }
  }
  if (bodies.empty()) return;
  physics::WorldOptions world_options;
  world_options.step_s = static_cast<double>(kSimulationStepNs) * 1e-9;
  world_options.hold = options_.world.hold ? physics::HoldMode::kUntilTorque : physics::HoldMode::kReleased;
  world_options.field = physics::field_shapes();
  for (const Eigen::Vector2d& ball : session_.extra_balls) {
    physics::BallOptions extra = world_options.ball;
    extra.position_m = Eigen::Vector3d(ball.x(), ball.y(), 0.0);
    world_options.extra_balls.push_back(extra);
  }
  int files_sweeps = 0;
  for (const RobotConfig& config : configs_) files_sweeps = std::max(files_sweeps, config.solver_iterations.value_or(0));
  world_options.solver_iterations =
      options_.world.solver_iterations.value_or(files_sweeps > 0 ? files_sweeps : world_options.solver_iterations);
  world_ = std::make_unique<physics::World>(physics::make_backend(*options_.world.physics), std::move(bodies),
                                            std::move(placements), world_options);
}

void Gateway::configure_state() {
  if (options_.state.dir.empty()) return;
  prepare_state_dir(options_.state.dir);
  for (std::size_t r = 0; r < configs_.size(); ++r) {
    state_files_.push_back(state_file_path(options_.state.dir, configs_[r], r));
  }
}

void Gateway::configure_robots() {
  // Saved EEPROM areas are read before any port exists: a bad state file stops doppel cleanly.
  std::vector<std::optional<RobotEeprom>> saved(configs_.size());
  for (std::size_t r = 0; r < state_files_.size() && !options_.state.fresh; ++r) {
    saved[r] = read_state(state_files_[r], configs_[r]);
  }
  const RobotBuilder builder(options_, world_.get());
  for (std::size_t r = 0; r < configs_.size(); ++r) {
    robots_.push_back(builder.runtime(configs_[r], r, in_world_[r], saved[r] ? &*saved[r] : nullptr,
                                      state_files_.empty() ? std::string() : state_files_[r]));
  }
}

void Gateway::configure_cameras() {
  if (!options_.cameras.enabled || (world_ == nullptr && session_.world_cameras.empty())) return;
  std::vector<std::vector<CameraSetup>> cameras(world_ != nullptr ? world_->robot_count() : 0);  // by world robot
  for (std::size_t r = 0; r < configs_.size(); ++r) {
    if (in_world_[r]) cameras[*in_world_[r]] = RobotBuilder::cameras(r, configs_[r].cameras);
  }
  cameras_ = std::make_unique<CameraFeed>(world_.get(), cameras, session_.world_cameras, options_);
}

void Gateway::configure_control() {
  if (!options_.viewer.enabled) return;
  // The viewer's page beside the API; without its files (no libjs-three) the API alone.
  control::StaticFiles files = control::default_static_files();
  if (!options_.viewer.dir.empty()) files.viewer_dir = options_.viewer.dir;
  if (const std::string problem = control::static_files_problem(files); !problem.empty()) {
    if (!options_.viewer.dir.empty()) throw std::runtime_error("--viewer-dir: " + problem);
    std::cerr << "doppel: viewer page off: " << problem << "\n";
    files = {};
  }
  viewer_page_ = !files.viewer_dir.empty();
  try {
    control_api_ = std::make_unique<control::HttpApi>(controller_->facets(), options_.viewer.address,
                                                      options_.viewer.port.value_or(control::kDefaultPort), files,
                                                      access_token_);
  } catch (const std::runtime_error& e) {
    if (options_.viewer.port) {
      throw std::runtime_error(std::string("--viewer: ") + e.what());
    }
    std::cerr << "doppel: simulation control off: " << e.what() << "; --viewer PORT picks another port\n";
  }
  if (control_api_ != nullptr) control_token_ = publish_token(control_api_->port());
}

void Gateway::configure_live_robots() {
  // The robots doppel started with are robots 0..n-1 of those added and removed while it runs.
  std::vector<contract::RobotAdded> started;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    std::vector<std::string> camera_names;
    for (std::size_t c = 0; cameras_ != nullptr && in_world_[r] && c < configs_[r].cameras.size(); ++c) {
      camera_names.push_back(RobotBuilder::camera_name(r, configs_[r].cameras[c].config.name));
    }
    RobotBuilder::Topics topics;
    if (truth_ != nullptr) {
      topics.transport = &truth_->transport_options();
      topics.world_model = truth_->settings(r).has_value();
      topics.sensor_levels = levels_feed_ != nullptr;
    }
    started.push_back(RobotBuilder::listing(r, configs_[r], *robots_[r], camera_names, topics));
  }
  const physics::FieldSpec field;
  live_ = std::make_unique<LiveRobots>(
      LiveRobots::Parts{&options_, world_.get(), links_.get(), cameras_.get(), controller_.get(), truth_.get(),
                        physics::carpet_half_length_m(field),
                        physics::carpet_half_width_m(field)},
      std::move(started));
}

void Gateway::start_handshake() {
  handshake_ = gateway::start_handshake(options_, *live_, access_token_, std::cerr);
  if (handshake_ != nullptr && handshake_->tcp_port() != 0) handshake_token_ = publish_token(handshake_->tcp_port());
}

std::optional<std::size_t> Gateway::world_index(std::size_t robot) const {
  return robot < in_world_.size() ? in_world_[robot] : std::nullopt;
}

void Gateway::configure_truth() {
  if (options_.truth.world_model && world_ == nullptr) {
    std::cerr << "doppel: --world-model: no robot has a body in the world (--physics none?): no world model\n";
  }
  if (!((options_.truth.world_model && world_ != nullptr) || options_.truth.sensor_levels_hz > 0.0)) return;
  truth::TruthOptions truth_options;
  truth_options.transport.iceoryx = options_.truth.iceoryx;
  truth_options.transport.udp_base_port = options_.truth.udp_port;
  truth_options.transport.udp_address = options_.truth.udp_address;
  truth_options.verbose = options_.cameras.verbose;
  try {
    truth_ = std::make_unique<truth::TruthService>(truth_options);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string(options_.truth.world_model ? "--world-model: " : "--sensor-levels: ") + e.what());
  }
  if (options_.truth.sensor_levels_hz > 0.0) {
    std::vector<RobotRuntime*> robots;
    for (auto& robot : robots_) robots.push_back(robot.get());
    levels_feed_ = std::make_unique<SensorLevelsFeed>(std::move(robots));
    truth_->add_poller([feed = levels_feed_.get()](truth::Transport& transport) { feed->publish(transport); });
  }
  for (std::size_t r = 0; r < configs_.size(); ++r) {
    if (!in_world_[r] || !options_.truth.world_model) continue;
    const truth::RobotBinding binding = RobotBuilder::truth_binding(configs_[r], *in_world_[r], start_placement(options_, r).team);
    if (const std::string problem = truth_->add_robot(r, binding, options_.truth.world_model_settings); !problem.empty()) {
      throw std::runtime_error("--world-model: " + problem);
    }
  }
  controller_->set_world_model(truth_.get());
}

contract::RobotHost& Gateway::robot_host() noexcept { return *live_; }

contract::Result<uint32_t> Gateway::add_fault(const faults::FaultSpec& spec) { return faults_->add(spec); }

void Gateway::configure_lockstep() {
  if (!options_.lockstep.enabled) return;
  std::vector<lockstep::LockstepBus> buses;
  for (auto& robot : robots_) {
    for (std::size_t b = 0; b < robot->bus_count(); ++b) {
      lockstep::LockstepBus bus;
      bus.link = robot->bus(b).link();
      bus.slave = robot->bus(b).slave_path();  // the link appears once the simulation thread serves the bus
      buses.push_back(bus);
    }
  }
  lockstep::CoordinatorOptions coordinator;
  coordinator.watchdog_ns = static_cast<int64_t>(options_.lockstep.watchdog_s * 1e9);
  if (options_.lockstep.epoch_s) coordinator.epoch_realtime_ns = static_cast<int64_t>(*options_.lockstep.epoch_s * 1e9);
  coordinator.start_ns = world_ != nullptr ? world_->time_ns() : 0;
  lockstep_ = std::make_unique<lockstep::Coordinator>(options_.buses.link_dir + "/" + lockstep::kClockFileName, buses, coordinator);
  for (auto& robot : robots_) {
    for (std::size_t b = 0; b < robot->bus_count(); ++b) {
      bus_hashes_.push_back(std::make_unique<Fnv1a>());
      robot->bus(b).server().use_lockstep_clock(&lockstep_->clock(), bus_hashes_.back().get());
    }
  }
  if (!options_.lockstep.hashes_file.empty()) {
    hashes_file_.open(options_.lockstep.hashes_file, std::ios::out | std::ios::trunc);
    if (!hashes_file_) throw std::runtime_error("--hashes-file: cannot write " + options_.lockstep.hashes_file);
  }
  if (options_.lockstep.hashes || !options_.lockstep.hashes_file.empty()) {
    std::ostream* out = options_.lockstep.hashes_file.empty() ? &std::cout : &hashes_file_;
    hash_callback_ = [out](int64_t second, uint64_t hash) {
      char line[64];
      std::snprintf(line, sizeof(line), "hash %" PRId64 " %016" PRIx64 "\n", second, hash);
      *out << line << std::flush;
    };
  }
}

void Gateway::on_second_hash(HashCallback callback) { hash_callback_ = std::move(callback); }

std::string Gateway::lockstep_clock_path() const { return lockstep_ != nullptr ? lockstep_->path() : std::string(); }

void Gateway::configure_recorder() {
  if (options_.record.path.empty()) return;
  const std::vector<RobotConfig>& configs = configs_;
  recording::RunInfo run;
  run.set_doppel_version(DOPPEL_VERSION);
  run.set_command_line(options_.command_line);
  run.set_start_monotonic_ns(monotonic_now_ns());
  run.set_start_unix_ns(clock_now_ns(CLOCK_REALTIME));
  run.set_physics_engine(world_ != nullptr ? std::string(physics::engine_name(*options_.world.physics)) : "");
  run.set_timing_mode(options_.buses.timing == bus::TimingMode::kWire ? "wire" : "fast");
  std::vector<record::RecordedBus> buses;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    for (std::size_t b = 0; b < robots_[r]->bus_count(); ++b) {
      BusRuntime& runtime = robots_[r]->bus(b);
      const BusConfig& config = configs[r].buses[b];
      record::RecordedBus bus;
      bus.tap = runtime.tap();
      recording::BusInfo& info = bus.info;
      info.set_robot(static_cast<uint32_t>(r));
      info.set_robot_name(configs[r].name);
      info.set_bus(static_cast<uint32_t>(b));
      info.set_link(runtime.link());
      info.set_configured_baud_bps(config.baud_bps);
      info.set_adapter_latency_ms(runtime.server().adapter_latency_ms());
      info.set_adapter(config.adapter == bus::AdapterProfile::kUsb2ax ? "usb2ax" : "ftdi");
      info.set_processing_ns(runtime.server().options().processing_ns);
      for (std::size_t i = 0; i < config.devices.size(); ++i) {
        const DeviceConfig& device = config.devices[i];
        recording::DeviceInfo* d = info.add_devices();
        d->set_id(device.id);
        d->set_name(device.name);
        d->set_model(device.model);
        d->set_protocol(device.firmware == dynamixel::Protocol::kV2 ? 2 : 1);
        d->set_return_delay_us(runtime.return_delay_us(i));  // the bus threads have not started yet
      }
      buses.push_back(std::move(bus));
    }
  }
  record::RecorderOptions recorder_options;
  recorder_options.path = options_.record.path;
  recorder_options.camera_hz = options_.record.camera_hz;
  recorder_options.compression = options_.record.compression == "lz4"    ? mcap::Compression::kLz4
                                 : options_.record.compression == "none" ? mcap::Compression::kNone
                                                                         : mcap::Compression::kZstd;
  recorder_options.progress = options_.record.progress && ::isatty(STDERR_FILENO) == 1;
  try {
    recorder_ = std::make_unique<record::Recorder>(recorder_options, std::move(run), std::move(buses), controller_->facets(),
                                                   controller_->keep_published_states(), &std::cerr);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("--record: ") + e.what());
  }
}

Gateway::~Gateway() { lifecycle_.release(); }

std::unique_ptr<contract::TokenFile> Gateway::publish_token(uint16_t port) const {
  if (access_token_.empty()) return nullptr;
  return std::make_unique<contract::TokenFile>(contract::token_file_path(links_->path(), port), access_token_);
}

teamcomm::Hub* Gateway::teamcomm_hub() noexcept { return field_ != nullptr ? field_->hub() : nullptr; }

uint16_t Gateway::control_port() const noexcept { return control_api_ != nullptr ? control_api_->port() : 0; }

void Gateway::start() { lifecycle_.start(); }

bool Gateway::save_state(bool published) {
  bool ok = true;
  for (std::size_t r = 0; r < state_files_.size(); ++r) {
    RobotRuntime& robot = *robots_[r];
    try {
      write_file_atomically(state_files_[r], state_json(robot.config(), published ? robot.published_eeprom() : robot.eeprom_now(),
                                                        robot.model_numbers()));
    } catch (const std::exception& e) {
      std::cerr << "doppel: " << e.what() << "\n" << std::flush;
      ok = false;
    }
  }
  return ok;
}

void Gateway::keep_state() noexcept {
  // A driver that changes several EEPROM items writes them in a burst: save once it has been quiet
  // for kQuiet (or kLongest after the first change, for a driver that never stops).
  using Clock = std::chrono::steady_clock;
  constexpr auto kPoll = std::chrono::milliseconds(50);
  constexpr auto kQuiet = std::chrono::milliseconds(200);
  constexpr auto kLongest = std::chrono::seconds(2);
  std::vector<uint64_t> saved_generation(robots_.size());
  std::vector<uint64_t> seen_generation(robots_.size());
  std::vector<Clock::time_point> first_change(robots_.size());
  std::vector<Clock::time_point> last_change(robots_.size());
  std::vector<bool> failed(robots_.size());
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    saved_generation[r] = seen_generation[r] = robots_[r]->eeprom_generation();
  }
  while (!state_stop_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(kPoll);
    const Clock::time_point now = Clock::now();
    for (std::size_t r = 0; r < robots_.size(); ++r) {
      const uint64_t generation = robots_[r]->eeprom_generation();
      if (generation == saved_generation[r]) {
        continue;
      }
      if (seen_generation[r] == saved_generation[r]) {
        first_change[r] = now;
      }
      if (generation != seen_generation[r]) {
        seen_generation[r] = generation;
        last_change[r] = now;
      }
      if (now - last_change[r] < kQuiet && now - first_change[r] < kLongest) {
        continue;
      }
      try {
        RobotRuntime& robot = *robots_[r];
        write_file_atomically(state_files_[r], state_json(robot.config(), robot.published_eeprom(), robot.model_numbers()));
        saved_generation[r] = generation;
        failed[r] = false;
      } catch (const std::exception& e) {
        if (!failed[r]) {
          std::cerr << "doppel: " << e.what() << " (will retry)\n" << std::flush;
        }
        failed[r] = true;
        first_change[r] = last_change[r] = now;
      }
    }
  }
}

void Gateway::stop() { lifecycle_.stop(); }

void Gateway::step_world(int64_t& sim_time_ns) noexcept {
  const double dt_s = static_cast<double>(kSimulationStepNs) * 1e-9;
  for (auto& robot : robots_) {
    robot->drive(dt_s);
  }
  live_->drive(dt_s);
  if (world_ != nullptr) {
    world_->step();
    sim_time_ns = world_->time_ns();
    if (step_observer_ != nullptr) {
      step_observer_->after_step(*world_, sim_time_ns);
    }
  } else {
    sim_time_ns += kSimulationStepNs;
  }
  if (cameras_ != nullptr) {
    cameras_->offer(world_.get(), sim_time_ns);
  }
  for (auto& robot : robots_) {
    robot->sense(sim_time_ns);
  }
  if (truth_ != nullptr) {
    truth_->capture(*world_, sim_time_ns);
  }
  live_->sense(sim_time_ns);
  sim_time_ns_.store(sim_time_ns, std::memory_order_relaxed);
}

void Gateway::simulate() noexcept {
  FixedRateClock clock(kSimulationStepNs);
  int64_t sim_time_ns = world_ != nullptr ? world_->time_ns() : 0;
  while (!simulation_stop_.load(std::memory_order_relaxed)) {
    live_->run_pending();  // a robot added or removed: this tick may overrun
    // Paused (doppel-ctl pause), the world and the sensors' time stand still; the buses answer on.
    if (controller_->begin_tick()) {
      step_world(sim_time_ns);
    }
    controller_->end_tick(sim_time_ns, clock.missed_ticks());
    clock.wait_next();
  }
  missed_ticks_ = clock.missed_ticks();
}

void Gateway::simulate_lockstep() noexcept {
  // The loop of docs/lockstep.md: let the controller run until all its threads wait; hand the
  // bytes it wrote to the bus servers and write what is due; wake one thread whose wait is over;
  // when none is, advance simulation time to the next event (a wake-up, a reply due, the next
  // 1 ms step) and step the world at each step boundary.
  constexpr int64_t kSettleNs = 1'000'000'000;  // wall time the pty may take to hand bytes over
  constexpr int64_t kSecondNs = 1'000'000'000;
  int64_t sim_time_ns = world_ != nullptr ? world_->time_ns() : 0;  // the world's (stands still while paused)
  int64_t next_step_ns = lockstep_->now_ns() + kSimulationStepNs;
  int64_t next_second_ns = (lockstep_->now_ns() / kSecondNs + 1) * kSecondNs;
  Fnv1a world_hash;
  bool told_waiting = false;
  bool stepped = true;  // the pty is polled at each step even when the controller wrote nothing
  const auto serve_buses = [this, &stepped] {
    std::size_t index = 0;
    for (auto& robot : robots_) {
      for (std::size_t b = 0; b < robot->bus_count(); ++b, ++index) {
        bus::BusServer& server = robot->bus(b).server();
        server.serve_lockstep(lockstep_->client_written(index), kSettleNs, stepped);
        lockstep_->set_delivered(index, server.bytes_out());
      }
    }
    stepped = false;
  };
  while (!simulation_stop_.load(std::memory_order_relaxed)) {
    if (!lockstep_->settle(simulation_stop_)) break;
    serve_buses();
    if (lockstep_->wake_one()) continue;
    if (lockstep_->threads() == 0) {
      if (!told_waiting) {
        std::cerr << "doppel: lockstep: simulation time stands at " << static_cast<double>(lockstep_->now_ns()) * 1e-9
                  << " s until a controller started with `doppel-run --lockstep` runs\n"
                  << std::flush;
        told_waiting = true;
      }
      lockstep_->wait_for_threads(50'000'000);
      continue;
    }
    told_waiting = false;
    int64_t next_ns = std::min(next_step_ns, lockstep_->earliest_wake_ns());
    for (auto& robot : robots_) {
      for (std::size_t b = 0; b < robot->bus_count(); ++b) {
        next_ns = std::min(next_ns, robot->bus(b).server().next_due_ns());
      }
    }
    lockstep_->advance_to(std::max(next_ns, lockstep_->now_ns()));
    if (lockstep_->now_ns() < next_step_ns) continue;
    next_step_ns += kSimulationStepNs;
    stepped = true;
    if (controller_->begin_tick()) {
      step_world(sim_time_ns);
      // A frame due now is published before any controller thread sees this time (docs/lockstep.md).
      if (cameras_ != nullptr) cameras_->wait_rendered();
    }
    controller_->end_tick(sim_time_ns, 0);
    world_hash.add_i64(sim_time_ns);
    if (world_ != nullptr) {
      for (std::size_t r = 0; r < world_->robot_count(); ++r) {
        for (std::size_t body = 0; body < world_->robot(r).bodies.size(); ++body) {
          const Eigen::Isometry3d pose = world_->body_pose(r, body);
          for (int i = 0; i < 3; ++i) world_hash.add_double(pose.translation()[i]);
          for (int i = 0; i < 9; ++i) world_hash.add_double(pose.linear().data()[i]);
        }
      }
      const Eigen::Vector3d ball = world_->ball_position();
      for (int i = 0; i < 3; ++i) world_hash.add_double(ball[i]);
    }
    if (lockstep_->now_ns() >= next_second_ns) {
      Fnv1a second;
      second.add_i64(next_second_ns);
      second.add_u64(world_hash.value());
      for (auto& hash : bus_hashes_) {
        second.add_u64(hash->value());
        hash->reset();
      }
      world_hash.reset();
      if (hash_callback_) hash_callback_(next_second_ns / kSecondNs, second.value());
      next_second_ns += kSecondNs;
    }
  }
}

std::string Gateway::describe() const {
  std::ostringstream out;
  if (handshake_ != nullptr) out << handshake_->describe();
  for (const auto& robot : robots_) {
    out << robot->describe();
  }
  if (cameras_ != nullptr) {
    out << cameras_->describe();
  }
  if (truth_ != nullptr && options_.truth.world_model) {
    out << truth_->describe();
  }
  if (levels_feed_ != nullptr) {
    const truth::TransportOptions& transport = truth_->transport_options();
    out << "doppel: sensor levels " << options_.truth.sensor_levels_hz << " times per simulated second on";
    if (transport.iceoryx) out << " iceoryx (" << truth::kServiceId << ", robot<N>, " << kSensorLevelsTopic << ")";
    if (transport.iceoryx && transport.udp) out << " and";
    if (transport.udp) out << " UDP " << transport.udp_address << ":" << transport.udp_base_port << "+N";
    out << " (doppel-truth --topic " << kSensorLevelsTopic << ")\n";
  }
  if (control_api_ != nullptr) {
    out << "doppel: simulation control on http://" << control_api_->address() << ":" << control_api_->port()
        << "/api/state (doppel-ctl --url http://" << control_api_->address() << ":" << control_api_->port() << ")\n";
    if (viewer_page_) {
      out << "doppel: viewer on http://" << control_api_->address() << ":" << control_api_->port() << "/"
          << (access_token_.empty() ? "" : "?token=" + access_token_) << "\n";
    }
  }
  for (const contract::TokenFile* file : {control_token_.get(), handshake_token_.get()}) {
    if (file == nullptr) continue;
    out << "doppel: access token in " << file->path() << " (doppel-ctl, doppel_session.py read it; docs/security.md)\n";
  }
  out << field_->describe();
  const char* timing = options_.buses.timing == bus::TimingMode::kWire ? "wire" : "fast";
  out << "doppel: physics " << (world_ != nullptr ? physics::engine_name(*options_.world.physics) : std::string_view("none (kinematic joints)"))
      << (world_ != nullptr && options_.world.hold ? ", robots held until their servos have torque" : "") << "\n";
  if (lockstep_ != nullptr) {
    out << "doppel: lockstep: simulation time runs while controllers started with `doppel-run --lockstep --link-dir "
        << options_.buses.link_dir << " -- CONTROLLER` wait (clock file " << lockstep_->path() << ")\n";
  }
  out << "doppel: timing " << timing << ", firmware time " << options_.buses.processing_us << " us, USB latency timer "
      << (options_.buses.latency_timer_ms == 0 ? std::string("off") : std::to_string(options_.buses.latency_timer_ms) + " ms")
      << "; running until SIGINT/SIGTERM\n";
  return out.str();
}

std::string Gateway::summary() const {
  std::ostringstream out;
  for (const auto& robot : robots_) {
    out << robot->summary();
  }
  if (live_ != nullptr) {
    out << live_->summary();
  }
  if (cameras_ != nullptr) {
    out << cameras_->summary();
  }
  if (truth_ != nullptr) {
    const truth::TruthStats stats = truth_->stats();
    if (levels_feed_ != nullptr) out << "  sensor levels: " << levels_feed_->messages() << " messages\n";
    if (options_.truth.world_model) {
      out << "  world model: " << stats.messages << " messages, " << stats.samples_dropped << " world samples dropped\n";
    }
    out << "  truth transport: iceoryx " << stats.transport.iceoryx_sent << " sent, " << stats.transport.iceoryx_dropped
        << " dropped; UDP " << stats.transport.udp_sent << " sent, " << stats.transport.udp_failed << " failed\n";
  }
  out << "  simulation: " << missed_ticks_ << " missed 1 ms ticks\n";
  if (recorder_ != nullptr) {
    out << recorder_->summary();
  }
  return out.str();
}

}  // namespace doppel::gateway
