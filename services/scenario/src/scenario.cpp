#include "scenario/scenario.h"

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <numbers>
#include <set>
#include <stdexcept>

#include "proto/scenario_file.h"

namespace doppel::scenario {
namespace {

bool name_chars(const std::string& text, const char* extra) {
  if (text.empty()) return false;
  for (char c : text) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    std::string_view(extra).find(c) != std::string_view::npos;
    if (!ok) return false;
  }
  return true;
}

// A time of the schedule: finite, within [0, duration).
void check_time(const proto::ScenarioFile& file, const google::protobuf::Message& entry, double time_s,
                double spread_s, double duration_s) {
  if (!std::isfinite(time_s) || time_s < 0.0) {
    file.fail(entry, "time_s", -1, "must be a finite time >= 0 s");
  }
  if (time_s >= duration_s) {
    file.fail(entry, "time_s", -1,
              "at " + std::to_string(time_s) + " s, not before the end of the run (duration_s " +
                  std::to_string(duration_s) + ")");
  }
  if (!std::isfinite(spread_s) || spread_s < 0.0) {
    file.fail(entry, "time_spread_s", -1, "must be finite and >= 0 s");
  }
}

void check_finite(const proto::ScenarioFile& file, const google::protobuf::Message& entry,
                  std::initializer_list<std::pair<const char*, double>> fields, double limit, const char* unit) {
  for (const auto& [field, value] : fields) {
    if (!std::isfinite(value) || std::fabs(value) > limit) {
      file.fail(entry, field, -1, "must be finite and within +-" + std::to_string(static_cast<int>(limit)) + " " + unit);
    }
  }
}

// Every '{...}' of an argument names a known placeholder, an existing robot and bus, a parameter
// of the file: a typo is found before anything runs.
void check_placeholders(const proto::ScenarioFile& file, const proto::Controller& controller, int index,
                        const Scenario& scenario) {
  Substitutions probe;
  for (const RobotEntry& robot : scenario.robots) {
    probe.links.emplace_back(robot.config.buses.size(), "link");
  }
  probe.params = scenario.params;
  try {
    substitute(controller.argv(index), controller.robot(), probe, "");
  } catch (const std::invalid_argument& e) {
    file.fail(controller, "argv", index, e.what());
  }
}

Scenario check(const proto::ScenarioFile& file, const std::string& robots_dir) {
  const proto::Scenario& in = file.scenario();
  Scenario out;
  out.source = file.path();
  out.folder = std::filesystem::path(file.path()).parent_path().string();
  if (out.folder.empty()) out.folder = ".";
  out.name = in.name();
  out.description = in.description();
  if (!name_chars(in.name(), ".-")) {
    file.fail(in, "name", -1, in.name().empty() ? "missing scenario name" : "use letters, digits, '_', '.', '-'");
  }
  if (!std::isfinite(in.duration_s()) || in.duration_s() <= 0.0 || in.duration_s() > kMaxDurationS) {
    file.fail(in, "duration_s", -1, "must be > 0 and at most 86400 simulated seconds");
  }
  out.duration_s = in.duration_s();
  if (in.robot_size() == 0) {
    file.fail(in, "robot", -1, "a scenario needs at least one robot");
  }
  for (int r = 0; r < in.robot_size(); ++r) {
    const proto::ScenarioRobot& robot = in.robot(r);
    if (robot.name().empty() == robot.file().empty()) {
      file.fail(in, "robot", r, "give exactly one of name (a shipped robot) or file");
    }
    RobotEntry entry;
    if (!robot.file().empty()) {
      std::filesystem::path path(robot.file());
      if (path.is_relative()) path = std::filesystem::path(out.folder) / path;
      entry.reference = path.string();
    } else {
      if (robot.name().find('/') != std::string::npos) {
        file.fail(robot, "name", -1, "a name, not a path (use file: for a robot file)");
      }
      entry.reference = robot.name();
    }
    try {
      entry.config = gateway::load_robot(entry.reference, robots_dir);
    } catch (const std::exception& e) {
      file.fail(robot, robot.file().empty() ? "name" : "file", -1, e.what());
    }
    if (!entry.config.body) {
      file.fail(robot, robot.file().empty() ? "name" : "file", -1,
                "robot '" + entry.config.name + "' has no figure (body): a scenario measures bodies");
    }
    if (robot.has_start()) {
      const proto::StartPose& start = robot.start();
      check_finite(file, start, {{"x_m", start.x_m()}, {"y_m", start.y_m()}}, 100.0, "m");
      check_finite(file, start, {{"yaw_deg", start.yaw_deg()}}, 360.0, "deg");
      entry.start = StartPose{start.x_m(), start.y_m(), start.yaw_deg() * std::numbers::pi / 180.0};
    }
    out.robots.push_back(std::move(entry));
  }
  for (int p = 0; p < in.param_size(); ++p) {
    const proto::Parameter& param = in.param(p);
    if (!name_chars(param.name(), "")) {
      file.fail(param, "name", -1, param.name().empty() ? "missing parameter name" : "use letters, digits and '_'");
    }
    if (!out.params.emplace(param.name(), param.value()).second) {
      file.fail(param, "name", -1, "parameter '" + param.name() + "' is given twice");
    }
  }
  for (int i = 0; i < in.push_size(); ++i) {
    const proto::Push& push = in.push(i);
    check_time(file, push, push.time_s(), push.time_spread_s(), out.duration_s);
    if (push.robot() >= out.robots.size()) {
      file.fail(push, "robot", -1, "robot " + std::to_string(push.robot()) + " does not exist (the file has " +
                                       std::to_string(out.robots.size()) + ")");
    }
    check_finite(file, push, {{"fx_n", push.fx_n()}, {"fy_n", push.fy_n()}, {"fz_n", push.fz_n()}}, 10000.0, "N");
    const double steps = std::round(push.duration_s() * 1000.0);
    if (!std::isfinite(push.duration_s()) || push.duration_s() <= 0.0 || steps < 1.0 || steps > 1e9 ||
        std::fabs(steps - push.duration_s() * 1000.0) > 1e-6) {
      file.fail(push, "duration_s", -1, "must be > 0 s in whole milliseconds (simulation steps)");
    }
    out.pushes.push_back({push.time_s(), push.time_spread_s(), push.robot(), push.fx_n(), push.fy_n(), push.fz_n(),
                          static_cast<uint32_t>(steps), file.location(in, "push", i)});
  }
  for (int i = 0; i < in.fault_size(); ++i) {
    const proto::FaultEvent& fault = in.fault(i);
    const std::optional<faults::FaultKind> kind = faults::fault_kind(fault.kind());
    if (!kind) file.fail(fault, "kind", -1, "must be one of " + faults::fault_kind_names());
    check_time(file, fault, fault.time_s(), 0.0, out.duration_s);
    if (fault.robot() >= out.robots.size()) {
      file.fail(fault, "robot", -1, "robot " + std::to_string(fault.robot()) + " does not exist (the file has " +
                                        std::to_string(out.robots.size()) + ")");
    }
    if (!std::isfinite(fault.duration_s()) || fault.duration_s() < 0.0) {
      file.fail(fault, "duration_s", -1, "must be finite and >= 0 s (0: to the end of the run)");
    }
    FaultEvent event;
    event.spec.kind = *kind;
    event.spec.robot = fault.robot();
    event.spec.bus = fault.has_bus() ? static_cast<int32_t>(std::min<uint32_t>(fault.bus(), 255)) : -1;
    event.spec.id = fault.has_id() ? static_cast<int32_t>(std::min<uint32_t>(fault.id(), 254)) : -1;
    event.spec.start_ns = std::llround(fault.time_s() * 1e9);
    event.spec.duration_ns = std::llround(std::min(fault.duration_s(), 1e7) * 1e9);
    event.spec.value = fault.value();
    event.spec.rate = fault.rate();
    event.spec.seed = fault.seed();
    event.seed_from_run = fault.seed() == 0;
    const faults::FaultKindInfo& info = faults::info(*kind);
    if (info.value_field.empty() && fault.value() != 0.0) {
      file.fail(fault, "value", -1, "kind " + std::string(info.name) + " takes no value");
    }
    if (!info.needs_rate && fault.rate() != 0.0) {
      file.fail(fault, "rate", -1, "kind " + std::string(info.name) + " takes no rate");
    }
    if (std::string problem = faults::check(event.spec); !problem.empty()) {
      // faults::check names the control API's fields; the file has `value` and `time_s`.
      const std::string value_field(info.value_field);
      std::string field = "kind";
      for (const char* name : {"bus", "id", "rate", "duration_s", "start_s"}) {
        if (problem.find(std::string("'") + name + "'") != std::string::npos) field = name;
      }
      if (!value_field.empty() && problem.find("'" + value_field + "'") != std::string::npos) field = "value";
      if (field == "start_s") field = "time_s";
      file.fail(fault, field, -1, problem);
    }
    event.location = file.location(in, "fault", i);
    out.faults.push_back(std::move(event));
  }
  for (int i = 0; i < in.ball_size(); ++i) {
    const proto::BallMove& ball = in.ball(i);
    check_time(file, ball, ball.time_s(), ball.time_spread_s(), out.duration_s);
    check_finite(file, ball, {{"x_m", ball.x_m()}, {"y_m", ball.y_m()}}, 100.0, "m");
    check_finite(file, ball, {{"vx_m_s", ball.vx_m_s()}, {"vy_m_s", ball.vy_m_s()}}, 50.0, "m/s");
    out.balls.push_back({ball.time_s(), ball.time_spread_s(), ball.x_m(), ball.y_m(), ball.vx_m_s(), ball.vy_m_s(),
                         file.location(in, "ball", i)});
  }
  for (int c = 0; c < in.controller_size(); ++c) {
    const proto::Controller& controller = in.controller(c);
    if (controller.argv_size() == 0 || controller.argv(0).empty()) {
      file.fail(controller, "argv", -1, "missing command (argv: \"program\" argv: \"argument\" ...)");
    }
    if (controller.robot() >= out.robots.size()) {
      file.fail(controller, "robot", -1, "robot " + std::to_string(controller.robot()) + " does not exist (the file has " +
                                             std::to_string(out.robots.size()) + ")");
    }
    for (int a = 0; a < controller.argv_size(); ++a) {
      check_placeholders(file, controller, a, out);
    }
    ControllerSpec spec;
    spec.argv.assign(controller.argv().begin(), controller.argv().end());
    spec.robot = controller.robot();
    spec.doppel_run = controller.doppel_run();
    spec.location = file.location(in, "controller", c);
    out.controllers.push_back(std::move(spec));
  }
  const proto::Metrics& metrics = in.metrics();
  if (metrics.distance() || metrics.time_to_fall() || metrics.energy() || metrics.peak_tilt() ||
      metrics.control_cycle()) {
    out.metrics = {metrics.distance(), metrics.time_to_fall(), metrics.energy(), metrics.peak_tilt(),
                   metrics.control_cycle()};
  }
  out.lockstep = in.lockstep();
  if (!in.physics().empty()) {
    if (in.physics() != "ode" && in.physics() != "bullet") {
      file.fail(in, "physics", -1, "'" + in.physics() + "' is no engine (ode or bullet)");
    }
    out.engine = physics::engine_from_name(in.physics());
  }
  out.seed = in.seed();
  return out;
}

}  // namespace

Scenario load_scenario(const std::string& path, const std::string& robots_dir) {
  return check(proto::ScenarioFile::load(path), robots_dir);
}

Scenario parse_scenario(const std::string& text, const std::string& path, const std::string& robots_dir) {
  return check(proto::ScenarioFile::parse(text, path), robots_dir);
}

std::pair<std::string, std::string> parse_param(const std::string& text) {
  const std::size_t equals = text.find('=');
  if (equals == std::string::npos || !name_chars(text.substr(0, equals), "")) {
    throw std::invalid_argument("--param '" + text + "': expected NAME=VALUE (NAME of letters, digits, '_')");
  }
  return {text.substr(0, equals), text.substr(equals + 1)};
}

std::string substitute(const std::string& argument, std::size_t robot, const Substitutions& values,
                       const std::string& location) {
  std::string out;
  std::size_t at = 0;
  while (true) {
    const std::size_t open = argument.find('{', at);
    out += argument.substr(at, open == std::string::npos ? std::string::npos : open - at);
    if (open == std::string::npos) break;
    const std::size_t close = argument.find('}', open);
    if (close == std::string::npos) {
      throw std::invalid_argument((location.empty() ? "" : location + ": ") + "'{' without '}' in \"" + argument + "\"");
    }
    const std::string key = argument.substr(open + 1, close - open - 1);
    const auto fail = [&](const std::string& what) {
      throw std::invalid_argument((location.empty() ? "" : location + ": ") + "{" + key + "}: " + what);
    };
    if (key == "link_dir") {
      out += values.link_dir;
    } else if (key == "seconds") {
      std::ostringstream text;
      text << std::setprecision(15) << values.seconds;  // 20, 2.5: as a person writes them
      out += text.str();
    } else if (key == "seed") {
      out += std::to_string(values.seed);
    } else if (key.rfind("param:", 0) == 0) {
      const auto found = values.params.find(key.substr(6));
      if (found == values.params.end()) fail("no such parameter");
      out += found->second;
    } else if (key.rfind("link:", 0) == 0) {
      const std::string spec = key.substr(5);
      std::size_t r = robot, b = 0;
      try {
        std::size_t used = 0;
        const std::size_t colon = spec.find(':');
        if (colon == std::string::npos) {
          b = std::stoul(spec, &used);
          if (used != spec.size()) fail("expected {link:BUS} or {link:ROBOT:BUS}");
        } else {
          r = std::stoul(spec.substr(0, colon), &used);
          if (used != colon) fail("expected {link:BUS} or {link:ROBOT:BUS}");
          b = std::stoul(spec.substr(colon + 1), &used);
          if (used != spec.size() - colon - 1) fail("expected {link:BUS} or {link:ROBOT:BUS}");
        }
      } catch (const std::logic_error&) {
        fail("expected {link:BUS} or {link:ROBOT:BUS}");
      }
      if (r >= values.links.size()) fail("robot " + std::to_string(r) + " does not exist");
      if (b >= values.links[r].size()) {
        fail("robot " + std::to_string(r) + " has " + std::to_string(values.links[r].size()) + " bus(es)");
      }
      out += values.links[r][b];
    } else {
      fail("unknown placeholder (known: {link:B}, {link:R:B}, {link_dir}, {seconds}, {seed}, {param:NAME})");
    }
    at = close + 1;
  }
  return out;
}

}  // namespace doppel::scenario
