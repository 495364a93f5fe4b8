#include "scenario/run.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "analyzer/analysis.h"
#include "analyzer/recording_reader.h"
#include "controller_process.h"
#include "observer.h"
#include "gateway/gateway.h"
#include "gateway/options.h"
#include "physics/world.h"
#include "scenario/metrics.h"

namespace doppel::scenario {
namespace {

// CLOCK_REALTIME of a lockstep controller at simulation time 0 (2026-01-01 00:00:00 UTC): fixed, so
// that a controller which stamps its logs with the date behaves the same in every run.
constexpr double kLockstepEpochS = 1767225600.0;

using nlohmann::json;

double degrees(double rad) { return rad * 180.0 / std::numbers::pi; }

// Rounds to 1e-9 (ns) so that the JSON shows simulation times without binary noise.
double tidy(double value) { return std::round(value * 1e9) / 1e9; }

std::string make_work_dir() {
  std::string base = "/tmp";
  if (const char* tmp = std::getenv("TMPDIR"); tmp != nullptr && *tmp != '\0') base = tmp;
  std::string pattern = base + "/doppel-scenario-XXXXXX";
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw std::runtime_error("cannot create a work directory under " + base + ": " + std::strerror(errno));
  }
  return pattern;
}

json cycle_json(const analyzer::CycleStats& cycle) {
  json out;
  out["found"] = cycle.found;
  if (!cycle.found) return out;
  out["opener"] = cycle.opener_kind;
  out["cycles"] = cycle.cycles;
  out["rate_hz"] = cycle.rate_hz;
  out["period_mean_ms"] = cycle.period.mean_ns * 1e-6;
  out["period_p50_ms"] = cycle.period.p50_ns * 1e-6;
  out["period_p99_ms"] = cycle.period.p99_ns * 1e-6;
  out["period_max_ms"] = cycle.period.max_ns * 1e-6;
  return out;
}

}  // namespace

std::vector<std::string> default_tool_dirs() {
  std::vector<std::string> dirs;
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) dirs.push_back(self.parent_path().string());
#ifdef DOPPEL_BUILD_TOOL_DIRS
  std::string list = DOPPEL_BUILD_TOOL_DIRS;
  std::size_t at = 0;
  while (at < list.size()) {
    const std::size_t semicolon = list.find(':', at);
    dirs.push_back(list.substr(at, semicolon == std::string::npos ? std::string::npos : semicolon - at));
    if (semicolon == std::string::npos) break;
    at = semicolon + 1;
  }
#endif
  return dirs;
}

json run_scenario(const Scenario& scenario, const RunOptions& options, const std::atomic<bool>* stop_requested) {
  const uint64_t seed = options.seed.value_or(scenario.seed);
  const double duration_s = options.duration_s.value_or(scenario.duration_s);
  const int64_t duration_ns = static_cast<int64_t>(std::llround(duration_s * 1e9));
  std::map<std::string, std::string> params = scenario.params;
  for (const auto& [name, value] : options.params) {
    if (!params.contains(name)) {
      std::string known;
      for (const auto& entry : scenario.params) known += (known.empty() ? "" : ", ") + entry.first;
      throw std::invalid_argument("--param " + name + ": " + scenario.source + " has no such param (it has: " +
                                  (known.empty() ? "none" : known) + ")");
    }
    params[name] = value;
  }

  const bool own_work_dir = options.work_dir.empty();
  const std::string work_dir = own_work_dir ? make_work_dir() : options.work_dir;
  struct Cleanup {
    std::string dir;
    ~Cleanup() {
      if (!dir.empty()) {
        std::error_code ignored;
        std::filesystem::remove_all(dir, ignored);
      }
    }
  } cleanup{own_work_dir ? work_dir : std::string()};
  if (!own_work_dir) std::filesystem::create_directories(work_dir);

  gateway::Options gateway_options;
  gateway_options.buses.link_dir = work_dir + "/links";
  gateway_options.viewer.enabled = false;
  gateway_options.cameras.enabled = false;
  gateway_options.state.dir = "";  // every run starts from the robot files
  gateway_options.state.fresh = true;
  gateway_options.world.physics = scenario.engine;
  if (scenario.lockstep) {
    // Simulation time only advances while the controllers wait (docs/lockstep.md); a fixed epoch
    // makes their CLOCK_REALTIME the same in every run, so equal runs hash equal.
    gateway_options.lockstep.enabled = true;
    gateway_options.lockstep.epoch_s = kLockstepEpochS;
  }
  if (scenario.metrics.control_cycle) {
    gateway_options.record.path = work_dir + "/run.mcap";
    gateway_options.record.compression = "none";
    gateway_options.record.progress = false;
  }
  gateway_options.command_line = "doppel scenario run " + scenario.source;
  std::vector<gateway::RobotConfig> configs;
  for (const RobotEntry& robot : scenario.robots) {
    gateway_options.buses.robots.push_back(robot.reference);
    configs.push_back(robot.config);
    if (robot.start) {
      physics::RobotPlacement placement;
      placement.position_m = Eigen::Vector3d(robot.start->x_m, robot.start->y_m, 0.0);
      placement.yaw_rad = robot.start->yaw_rad;
      placement.team = static_cast<uint8_t>(gateway_options.world.placements.size() % 2);
      gateway_options.world.placements.emplace_back(placement);
    } else {
      gateway_options.world.placements.emplace_back(std::nullopt);
    }
  }
  gateway::Gateway gateway(gateway_options, configs, gateway::SessionConfig{});

  // Every servo of every robot, for the energy.
  std::vector<std::vector<physics::MotorHandle>> motors(configs.size());
  Substitutions values;
  values.link_dir = gateway_options.buses.link_dir;
  values.seconds = duration_s;
  values.seed = seed;
  values.params = params;
  for (std::size_t r = 0; r < configs.size(); ++r) {
    if (gateway.world_index(r) != r) {
      throw std::runtime_error("robot " + std::to_string(r) + " (" + configs[r].name + ") is not in the physics world");
    }
    values.links.emplace_back();
    for (std::size_t b = 0; b < configs[r].buses.size(); ++b) {
      values.links.back().push_back(gateway::link_path(gateway_options.buses.link_dir, r, b));
    }
  }
  std::vector<std::vector<std::string>> argvs;
  for (const ControllerSpec& controller : scenario.controllers) {
    std::vector<std::string> argv;
    for (const std::string& argument : controller.argv) {
      argv.push_back(substitute(argument, controller.robot, values, controller.location));
    }
    const std::string program = find_program(argv[0], scenario.folder, options.tool_dirs);
    if (program.empty()) {
      throw std::runtime_error(controller.location + ": controller program '" + argv[0] +
                               "' not found (not an executable file; bare names are looked up beside doppel's tools and on PATH)");
    }
    argv[0] = program;
    if (controller.doppel_run || scenario.lockstep) {
      const std::string shim = find_program("doppel-run", scenario.folder, options.tool_dirs);
      if (shim.empty()) throw std::runtime_error(controller.location + ": doppel_run: doppel-run not found");
      std::vector<std::string> wrapped = {shim, "--link-dir", gateway_options.buses.link_dir};
      if (scenario.lockstep) wrapped.push_back("--lockstep");
      wrapped.push_back("--");
      wrapped.insert(wrapped.end(), argv.begin(), argv.end());
      argv = std::move(wrapped);
    }
    argvs.push_back(std::move(argv));
  }

  const physics::World* world = gateway.world();
  for (std::size_t r = 0; r < configs.size(); ++r) {
    for (std::size_t b = 0; b < configs[r].buses.size(); ++b) {
      for (const gateway::DeviceConfig& device : configs[r].buses[b].devices) {
        if (auto motor = world->find_motor(r, static_cast<uint32_t>(b), device.id)) motors[r].push_back(*motor);
      }
    }
  }
  // The file's faults, on the simulation clock (which starts at 0 with the run); their targets are
  // checked here, before anything runs.
  for (const FaultEvent& fault : scenario.faults) {
    faults::FaultSpec spec = fault.spec;
    if (fault.seed_from_run) spec.seed = seed;
    const contract::Result<uint32_t> added = gateway.add_fault(spec);
    if (!added.ok()) throw std::invalid_argument(fault.location + ": " + added.error().message);
  }
  ScenarioObserver observer(scenario, schedule(scenario, seed), duration_ns, std::move(motors));
  gateway.set_step_observer(&observer);
  // The run hash of every simulated second, handed over on the simulation thread: room for all of
  // them is made here, so that thread never allocates; read after stop() has joined it.
  std::vector<std::pair<int64_t, uint64_t>> hashes;
  if (scenario.lockstep) {
    hashes.reserve(static_cast<std::size_t>(duration_s) + 2);
    gateway.on_second_hash([&hashes](int64_t second, uint64_t hash) {
      if (hashes.size() < hashes.capacity()) hashes.emplace_back(second, hash);
    });
  }

  const auto wall_start = std::chrono::steady_clock::now();
  gateway.start();
  std::vector<std::unique_ptr<ControllerProcess>> controllers;
  try {
    for (std::size_t c = 0; c < argvs.size(); ++c) {
      controllers.push_back(std::make_unique<ControllerProcess>(argvs[c], work_dir + "/controller" + std::to_string(c)));
    }
  } catch (...) {
    controllers.clear();  // those already started
    gateway.stop();
    throw;
  }

  std::string ended = "duration";
  int64_t shown_second = 0;
  while (true) {
    if (observer.done()) break;
    if (stop_requested != nullptr && stop_requested->load()) {
      ended = "stopped";
      break;
    }
    if (!controllers.empty() &&
        std::all_of(controllers.begin(), controllers.end(), [](const auto& c) { return c->exited(); })) {
      ended = "controller_exited";
      break;
    }
    const int64_t second = observer.sim_time_ns() / 1'000'000'000;
    if (options.progress != nullptr && second > shown_second) {
      shown_second = second;
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      std::ostringstream line;
      line << "doppel scenario " << scenario.name << ": " << second << "/" << duration_s << " s simulated, "
           << std::fixed;
      line.precision(1);
      line << wall << " s wall";
      *options.progress << line.str() << (options.progress_terminal ? "\r" : "\n") << std::flush;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(options.stop_signal_poll_ms));
  }
  for (auto& controller : controllers) controller->stop();
  gateway.stop();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  if (options.progress != nullptr && options.progress_terminal) *options.progress << "\n" << std::flush;

  json result;
  result["scenario"] = scenario.name;
  result["file"] = scenario.source;
  result["seed"] = seed;
  result["lockstep"] = scenario.lockstep;
  if (scenario.lockstep) {
    json lines = json::array();
    for (const auto& [second, hash] : hashes) {
      char hex[17];
      std::snprintf(hex, sizeof(hex), "%016" PRIx64, hash);
      lines.push_back({{"second", second}, {"hash", hex}});
    }
    result["hashes"] = lines;
  }
  result["physics"] = std::string(physics::engine_name(scenario.engine));
  result["duration_s"] = duration_s;
  result["sim_time_s"] = tidy(static_cast<double>(observer.sim_time_ns()) * 1e-9);
  result["wall_time_s"] = wall_s;
  result["ended"] = ended;
  result["params"] = params;
  json robots = json::array();
  for (std::size_t r = 0; r < configs.size(); ++r) {
    json robot;
    robot["name"] = configs[r].name;
    robot["file"] = configs[r].source;
    robot["links"] = values.links[r];
    robots.push_back(robot);
  }
  result["robots"] = robots;
  json controllers_json = json::array();
  for (std::size_t c = 0; c < controllers.size(); ++c) {
    const ControllerProcess& process = *controllers[c];
    json entry;
    entry["argv"] = argvs[c];
    entry["robot"] = scenario.controllers[c].robot;
    entry["exit_code"] = process.exit_code() ? json(*process.exit_code()) : json(nullptr);
    entry["signal"] = process.signal() ? json(*process.signal()) : json(nullptr);
    entry["stopped_by_doppel"] = process.stopped_by_us();
    entry["stderr_tail"] = process.stderr_tail();
    entry["stdout_tail"] = process.stdout_tail();
    controllers_json.push_back(entry);
  }
  result["controllers"] = controllers_json;
  json events = json::array();
  for (std::size_t i = 0; i < observer.events().size(); ++i) {
    const Event& event = observer.events()[i];
    json entry;
    entry["kind"] = event.push ? "push" : "ball";
    entry["scheduled_s"] = tidy(static_cast<double>(event.at_ns) * 1e-9);
    entry["applied_s"] = observer.applied_ns()[i] >= 0 ? json(tidy(static_cast<double>(observer.applied_ns()[i]) * 1e-9))
                                                       : json(nullptr);
    if (event.push) {
      const PushEvent& push = scenario.pushes[event.index];
      entry["robot"] = push.robot;
      entry["force_n"] = {push.fx_n, push.fy_n, push.fz_n};
      entry["duration_s"] = push.steps * 1e-3;
    } else {
      const BallEvent& ball = scenario.balls[event.index];
      entry["position_m"] = {ball.x_m, ball.y_m};
      entry["velocity_m_s"] = {ball.vx_m_s, ball.vy_m_s};
    }
    events.push_back(entry);
  }
  result["events"] = events;
  json faults_json = json::array();
  for (const FaultEvent& fault : scenario.faults) {
    const faults::FaultSpec& spec = fault.spec;
    json entry = {{"kind", std::string(faults::info(spec.kind).name)}, {"robot", spec.robot},
                  {"start_s", tidy(static_cast<double>(spec.start_ns) * 1e-9)}};
    entry["end_s"] = spec.duration_ns == faults::kForever ? json(nullptr)
                                                          : json(tidy(static_cast<double>(spec.start_ns + spec.duration_ns) * 1e-9));
    if (spec.bus >= 0) entry["bus"] = spec.bus;
    if (spec.id >= 0) entry["id"] = spec.id;
    faults_json.push_back(entry);
  }
  result["faults"] = faults_json;

  std::vector<analyzer::CycleStats> cycles(configs.size());
  std::string cycle_problem;
  if (scenario.metrics.control_cycle) {
    try {
      const analyzer::Recording recording =
          analyzer::read_recording(gateway_options.record.path, std::nullopt, {}, false);
      for (std::size_t r = 0; r < configs.size(); ++r) {
        cycles[r] = analyzer::analyze(recording.run, recording.transactions, static_cast<uint32_t>(r)).cycle;
      }
    } catch (const std::exception& e) {
      cycle_problem = e.what();
    }
  }
  json metrics = json::array();
  for (std::size_t r = 0; r < configs.size(); ++r) {
    const RobotMetrics& m = observer.tracks()[r].metrics();
    json entry;
    entry["robot"] = r;
    entry["measured_s"] = tidy(m.time_s);
    if (scenario.metrics.distance) {
      entry["distance_m"] = m.distance_m;
      entry["forward_m"] = m.forward_m;
      entry["lateral_m"] = m.lateral_m;
      entry["end"] = {{"x_m", m.end_x_m}, {"y_m", m.end_y_m}, {"yaw_deg", degrees(m.end_yaw_rad)}};
    }
    if (scenario.metrics.time_to_fall) {
      entry["fallen"] = m.fall_time_s.has_value();
      entry["time_to_fall_s"] = m.fall_time_s ? json(tidy(*m.fall_time_s)) : json(nullptr);
    }
    if (scenario.metrics.energy) {
      entry["energy_j"] = m.energy_j;
      entry["energy_drawn_j"] = m.energy_drawn_j;
      entry["mean_power_w"] = m.time_s > 0.0 ? m.energy_j / m.time_s : 0.0;
    }
    if (scenario.metrics.peak_tilt) {
      entry["peak_tilt_deg"] = degrees(m.peak_tilt_rad);
      entry["peak_tilt_s"] = tidy(m.peak_tilt_time_s);
    }
    if (scenario.metrics.control_cycle) {
      entry["control_cycle"] = cycle_problem.empty() ? cycle_json(cycles[r]) : json({{"found", false}, {"error", cycle_problem}});
    }
    metrics.push_back(entry);
  }
  result["metrics"] = metrics;
  result["ball_end_m"] = {observer.ball().x(), observer.ball().y(), observer.ball().z()};
  return result;
}

}  // namespace doppel::scenario
