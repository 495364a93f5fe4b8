#pragma once
// A scenario file (libs/proto/scenario.proto, docs/scenarios.md) read and checked: robots loaded, the
// schedule sorted and in simulation steps, the controller's command with its placeholders checked.
// Setup code: errors throw std::invalid_argument ("file:line:column: Type.field: what") or
// std::runtime_error (unreadable file, syntax).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "faults/fault.h"
#include "gateway/robot_config.h"
#include "physics/engines.h"

namespace doppel::scenario {

inline constexpr int64_t kStepNs = 1'000'000;  // the gateway's fixed step
inline constexpr double kMaxDurationS = 24.0 * 3600.0;

struct StartPose {
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
};

struct RobotEntry {
  std::string reference;  // the name or file as the scenario wrote it (file: resolved from its folder)
  gateway::RobotConfig config;
  std::optional<StartPose> start;
};

struct PushEvent {
  double time_s = 0.0;
  double time_spread_s = 0.0;
  std::size_t robot = 0;
  double fx_n = 0.0, fy_n = 0.0, fz_n = 0.0;
  uint32_t steps = 0;  // duration in 1 ms steps
  std::string location;  // "file:line:column" of its entry
};

struct BallEvent {
  double time_s = 0.0;
  double time_spread_s = 0.0;
  double x_m = 0.0, y_m = 0.0, vx_m_s = 0.0, vy_m_s = 0.0;
  std::string location;
};

// A fault of the file, checked (faults::check) except for its target, which the gateway checks
// when the run starts. seed_from_run: the file gave none, the run's seed is used.
struct FaultEvent {
  faults::FaultSpec spec;
  bool seed_from_run = false;
  std::string location;
};

struct ControllerSpec {
  std::vector<std::string> argv;  // as written, placeholders not yet replaced
  std::size_t robot = 0;
  bool doppel_run = false;
  std::string location;
};

struct MetricSet {
  bool distance = true, time_to_fall = true, energy = true, peak_tilt = true, control_cycle = true;
};

struct Scenario {
  std::string source;      // the file
  std::string folder;      // its folder (relative commands and robot files start here)
  std::string name;
  std::string description;
  std::vector<RobotEntry> robots;
  double duration_s = 0.0;
  std::vector<PushEvent> pushes;   // in file order
  std::vector<BallEvent> balls;
  std::vector<FaultEvent> faults;  // in file order
  std::vector<ControllerSpec> controllers;
  std::map<std::string, std::string> params;  // defaults
  MetricSet metrics;
  bool lockstep = false;
  physics::Engine engine = physics::Engine::kOde;
  uint64_t seed = 0;
};

// Loads and checks `path`; robot names are looked up in `robots_dir`.
Scenario load_scenario(const std::string& path, const std::string& robots_dir);
// The same on text (tests); `path` names it in messages and gives the folder.
Scenario parse_scenario(const std::string& text, const std::string& path, const std::string& robots_dir);

// What the placeholders of a controller's argv stand for in one run.
struct Substitutions {
  std::vector<std::vector<std::string>> links;  // [robot][bus]
  std::string link_dir;
  double seconds = 0.0;
  uint64_t seed = 0;
  std::map<std::string, std::string> params;    // file defaults with --param overrides applied
};

// `argument` with every placeholder replaced. Throws std::invalid_argument naming `location`, the
// placeholder and what is wrong (unknown placeholder, robot or bus out of range, unknown parameter,
// an unclosed '{').
std::string substitute(const std::string& argument, std::size_t robot, const Substitutions& values,
                       const std::string& location);

// "NAME=VALUE" of --param; throws std::invalid_argument naming it.
std::pair<std::string, std::string> parse_param(const std::string& text);

}  // namespace doppel::scenario
