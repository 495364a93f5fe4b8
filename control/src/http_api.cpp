#include "control/http_api.h"

#include <httplib.h>
#include <sys/socket.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>

namespace doppel::control {
namespace {

using nlohmann::json;

// A request that cannot be applied as asked: its status and message.
struct Refused {
  int status;
  std::string message;
};

json error_body(const std::string& message) { return json{{"error", message}}; }

json parse_object(const std::string& body) {
  if (body.empty()) return json::object();
  json request = json::parse(body, nullptr, false);
  if (request.is_discarded()) throw Refused{400, "the request body is not JSON"};
  if (!request.is_object()) throw Refused{400, "the request body must be a JSON object"};
  return request;
}

void only_fields(const json& request, const std::set<std::string>& allowed) {
  for (const auto& [key, value] : request.items()) {
    if (allowed.count(key) == 0) throw Refused{400, "unknown field '" + key + "'"};
  }
}

double number(const json& request, const std::string& field) {
  if (!request.contains(field)) throw Refused{400, "missing field '" + field + "'"};
  const json& value = request.at(field);
  if (!value.is_number()) throw Refused{400, "field '" + field + "' must be a number"};
  const double x = value.get<double>();
  if (!std::isfinite(x)) throw Refused{400, "field '" + field + "' must be finite"};
  return x;
}

uint32_t milliseconds(const json& request, uint32_t most) {
  if (!request.contains("ms")) throw Refused{400, "missing field 'ms'"};
  const json& value = request.at("ms");
  if (!value.is_number_integer() && !value.is_number_unsigned()) throw Refused{400, "field 'ms' must be a whole number"};
  const int64_t ms = value.get<int64_t>();
  if (ms < 1 || ms > most) {
    throw Refused{400, "field 'ms' must be within 1.." + std::to_string(most) + ", got " + std::to_string(ms)};
  }
  return static_cast<uint32_t>(ms);
}

std::size_t robot_index(const json& request, const SimState& state) {
  if (!request.contains("robot")) throw Refused{400, "missing field 'robot' (a robot's index or name)"};
  const json& robot = request.at("robot");
  if (robot.is_number_integer() || robot.is_number_unsigned()) {
    const int64_t index = robot.get<int64_t>();
    if (index < 0 || static_cast<std::size_t>(index) >= state.robots.size()) {
      throw Refused{404, "no robot " + std::to_string(index) + " (there are " + std::to_string(state.robots.size()) + ")"};
    }
    return static_cast<std::size_t>(index);
  }
  if (!robot.is_string()) throw Refused{400, "field 'robot' must be a robot's index or name"};
  const std::string name = robot.get<std::string>();
  std::optional<std::size_t> found;
  for (std::size_t r = 0; r < state.robots.size(); ++r) {
    if (state.robots[r].name != name) continue;
    if (found) throw Refused{400, "two robots are named '" + name + "': give its index"};
    found = r;
  }
  if (!found) throw Refused{404, "no robot named '" + name + "'"};
  return *found;
}

void on_carpet(const SimState& state, double x, double y) {
  if (std::abs(x) > state.carpet_half_length_m || std::abs(y) > state.carpet_half_width_m) {
    throw Refused{400, "(" + json(x).dump() + ", " + json(y).dump() + ") is off the carpet (|x| <= " +
                           json(state.carpet_half_length_m).dump() + ", |y| <= " + json(state.carpet_half_width_m).dump() + " m)"};
  }
}

void simulated(const SimState& state, std::size_t robot) {
  if (!state.robots[robot].simulated) {
    throw Refused{409, "robot " + std::to_string(robot) + " '" + state.robots[robot].name +
                           "' has no body in the world (no figure, or --physics none)"};
  }
}

Outcome apply(SimControl& control, const std::string& action, const json& request) {
  if (action == "pause" || action == "resume" || action == "reset") {
    only_fields(request, {});
    return action == "pause" ? control.pause() : action == "resume" ? control.resume() : control.reset();
  }
  if (action == "step") {
    only_fields(request, {"ms"});
    return control.step(milliseconds(request, kMaxStepMs));
  }
  const SimState state = control.state();
  if (action == "place") {
    only_fields(request, {"robot", "x", "y", "yaw"});
    const std::size_t robot = robot_index(request, state);
    const double x = number(request, "x"), y = number(request, "y"), yaw = number(request, "yaw");
    on_carpet(state, x, y);
    simulated(state, robot);
    return control.place(robot, x, y, yaw);
  }
  if (action == "push") {
    only_fields(request, {"robot", "fx", "fy", "fz", "ms"});
    const std::size_t robot = robot_index(request, state);
    const double fx = number(request, "fx"), fy = number(request, "fy"), fz = number(request, "fz");
    if (std::sqrt(fx * fx + fy * fy + fz * fz) > kMaxPushForceN) {
      throw Refused{400, "a push of more than " + std::to_string(static_cast<int>(kMaxPushForceN)) + " N is refused"};
    }
    const uint32_t ms = milliseconds(request, kMaxPushMs);
    simulated(state, robot);
    return control.push(robot, fx, fy, fz, ms);
  }
  if (action == "ball") {
    only_fields(request, {"x", "y"});
    const double x = number(request, "x"), y = number(request, "y");
    if (!state.ball_m) throw Refused{409, "there is no ball (no world: --physics none or no robot with a body)"};
    on_carpet(state, x, y);
    return control.ball(x, y);
  }
  throw Refused{404, "no such request: /api/" + action};
}

// The checked fields of POST /api/replay against the replay's `status`: all or nothing.
ReplayChange replay_change(const json& request, const ReplayStatus& status) {
  only_fields(request, {"position_s", "speed", "playing"});
  if (request.empty()) throw Refused{400, "give at least one of 'position_s', 'speed', 'playing'"};
  ReplayChange change;
  if (request.contains("position_s")) {
    const double position = number(request, "position_s");
    if (position < status.start_s || position > status.end_s) {
      throw Refused{400, "field 'position_s' must be within " + json(status.start_s).dump() + ".." + json(status.end_s).dump() +
                             " s (the recording), got " + json(position).dump()};
    }
    change.position_s = position;
  }
  if (request.contains("speed")) {
    const double speed = number(request, "speed");
    if (speed < kMinReplaySpeed || speed > kMaxReplaySpeed) {
      throw Refused{400, "field 'speed' must be within " + json(kMinReplaySpeed).dump() + ".." + json(kMaxReplaySpeed).dump() +
                             ", got " + json(speed).dump()};
    }
    change.speed = speed;
  }
  if (request.contains("playing")) {
    if (!request.at("playing").is_boolean()) throw Refused{400, "field 'playing' must be true or false"};
    change.playing = request.at("playing").get<bool>();
  }
  return change;
}

Answer replay_request(SimControl& control, const std::string& method, const std::string& body) {
  const std::optional<ReplayStatus> status = control.replay();
  if (!status) return {404, error_body("this is not a replay: /api/replay is served by doppel-replay (docs/replay.md)")};
  if (method == "GET") return {200, replay_json(*status)};
  if (method != "POST") return {405, error_body("/api/replay is read with GET and changed with POST")};
  try {
    const Outcome outcome = control.change_replay(replay_change(parse_object(body), *status));
    if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
  } catch (const Refused& refused) {
    return {refused.status, error_body(refused.message)};
  }
  const std::optional<ReplayStatus> after = control.replay();
  return {200, after ? replay_json(*after) : json(nullptr)};
}

// GET/PUT /api/robots/N/world_model: a robot's world-model sensor settings; PUT changes the fields
// it names (the others stay), each checked for its type here and for its range by the sensor.
Answer world_model_request(SimControl& control, const std::string& method, const std::string& action, const std::string& body) {
  constexpr std::string_view kRobots = "robots/", kWorldModel = "/world_model";
  const std::string index = action.substr(kRobots.size(), action.size() - kRobots.size() - kWorldModel.size());
  if (index.empty() || index.size() > 6 || index.find_first_not_of("0123456789") != std::string::npos) {
    return {404, error_body("no such path: /api/" + action + " (/api/robots/N/world_model, N a robot's index)")};
  }
  const auto robot = static_cast<std::size_t>(std::stoul(index));
  WorldModelAnswer answer = control.world_model(robot);
  if (answer.status == 200 && method == "PUT") {
    try {
      const json request = parse_object(body);
      only_fields(request, {"enabled", "rate_hz", "fov_deg", "max_range_m", "nearest_ball_only", "position_sigma_m",
                            "angle_sigma_rad", "dropout", "latency_s", "seed"});
      WorldModelSettings settings = answer.settings;
      auto flag = [&](const char* field, bool& to) {
        if (!request.contains(field)) return;
        if (!request.at(field).is_boolean()) throw Refused{400, "field '" + std::string(field) + "' must be true or false"};
        to = request.at(field).get<bool>();
      };
      auto real = [&](const char* field, double& to) {
        if (request.contains(field)) to = number(request, field);
      };
      flag("enabled", settings.enabled);
      flag("nearest_ball_only", settings.nearest_ball_only);
      real("rate_hz", settings.rate_hz);
      real("fov_deg", settings.fov_deg);
      real("max_range_m", settings.max_range_m);
      real("position_sigma_m", settings.position_sigma_m);
      real("angle_sigma_rad", settings.angle_sigma_rad);
      real("dropout", settings.dropout);
      real("latency_s", settings.latency_s);
      if (request.contains("seed")) {
        const json& seed = request.at("seed");
        if (!seed.is_number_unsigned() && !(seed.is_number_integer() && seed.get<int64_t>() >= 0)) {
          throw Refused{400, "field 'seed' must be a whole number >= 0"};
        }
        settings.seed = seed.get<uint64_t>();
      }
      answer = control.set_world_model(robot, settings);
    } catch (const Refused& refused) {
      return {refused.status, error_body(refused.message)};
    }
  } else if (method != "GET" && method != "PUT") {
    return {405, error_body("/api/robots/N/world_model is read with GET and changed with PUT")};
  }
  if (answer.status != 200) return {answer.status, error_body(answer.error)};
  const WorldModelSettings& s = answer.settings;
  return {200, json{{"robot", robot},
                    {"enabled", s.enabled},
                    {"rate_hz", s.rate_hz},
                    {"fov_deg", s.fov_deg},
                    {"max_range_m", s.max_range_m},
                    {"nearest_ball_only", s.nearest_ball_only},
                    {"position_sigma_m", s.position_sigma_m},
                    {"angle_sigma_rad", s.angle_sigma_rad},
                    {"dropout", s.dropout},
                    {"latency_s", s.latency_s},
                    {"seed", s.seed}}};
}

// A team: "A" / "B" (index 0 / 1) or its team number.
int game_team(const json& request, const GameStatus& status, bool drop_ball_allowed = false) {
  if (!request.contains("team")) throw Refused{400, "missing field 'team' (A, B or a team number)"};
  const json& team = request.at("team");
  if (team.is_string()) {
    const std::string name = team.get<std::string>();
    if (name == "A" || name == "a") return 0;
    if (name == "B" || name == "b") return 1;
    if (drop_ball_allowed && name == "drop_ball") return -1;
  } else if (team.is_number_integer() || team.is_number_unsigned()) {
    const int64_t number = team.get<int64_t>();
    if (number == status.teams[0].number) return 0;
    if (number == status.teams[1].number) return 1;
  }
  throw Refused{400, "field 'team' must be A, B or a team number of this game (" + std::to_string(status.teams[0].number) +
                         ", " + std::to_string(status.teams[1].number) + ")" + (drop_ball_allowed ? " or drop_ball" : "") +
                         ", got " + team.dump()};
}

uint32_t whole(const json& request, const std::string& field, uint32_t least, uint32_t most) {
  if (!request.contains(field)) throw Refused{400, "missing field '" + field + "'"};
  const json& value = request.at(field);
  if (!value.is_number_integer() && !value.is_number_unsigned()) throw Refused{400, "field '" + field + "' must be a whole number"};
  const int64_t x = value.get<int64_t>();
  if (x < least || x > most) {
    throw Refused{400, "field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most) +
                           ", got " + std::to_string(x)};
  }
  return static_cast<uint32_t>(x);
}

std::string text(const json& request, const std::string& field, const std::set<std::string>& allowed) {
  if (!request.contains(field)) throw Refused{400, "missing field '" + field + "'"};
  const json& value = request.at(field);
  std::string names;
  for (const std::string& name : allowed) names += (names.empty() ? "" : ", ") + name;
  if (!value.is_string() || allowed.count(value.get<std::string>()) == 0) {
    throw Refused{400, "field '" + field + "' must be one of " + names + ", got " + value.dump()};
  }
  return value.get<std::string>();
}

GameCommand game_command(const json& request, const GameStatus& status) {
  GameCommand command;
  command.command = text(request, "command",
                         {"on", "off", "state", "goal", "score", "kickoff", "penalize", "unpenalize", "set_play", "timeout", "normal"});
  const std::string& c = command.command;
  if (c == "on" || c == "off" || c == "normal") {
    only_fields(request, {"command"});
  } else if (c == "state") {
    only_fields(request, {"command", "state"});
    command.state = text(request, "state", {"initial", "ready", "set", "playing", "finished"});
  } else if (c == "goal" || c == "timeout") {
    only_fields(request, {"command", "team"});
    command.team = game_team(request, status);
  } else if (c == "score") {
    only_fields(request, {"command", "team", "score"});
    command.team = game_team(request, status);
    command.score = whole(request, "score", 0, 255);
  } else if (c == "kickoff") {
    only_fields(request, {"command", "team"});
    command.team = game_team(request, status, true);
  } else if (c == "penalize" || c == "unpenalize") {
    only_fields(request, c == "penalize" ? std::set<std::string>{"command", "team", "player", "seconds", "reason"}
                                         : std::set<std::string>{"command", "team", "player"});
    command.team = game_team(request, status);
    command.player = whole(request, "player", 1, kMaxGamePlayers);
    if (c == "penalize") {
      if (request.contains("seconds")) command.seconds = whole(request, "seconds", 0, 255);
      if (request.contains("reason")) {
        std::set<std::string> names;
        for (const GamePenaltyName& penalty : kGamePenalties) names.insert(penalty.name);
        const std::string reason = text(request, "reason", names);
        for (const GamePenaltyName& penalty : kGamePenalties) {
          if (reason == penalty.name) command.penalty = penalty.code;
        }
      }
    }
  } else {  // set_play
    only_fields(request, {"command", "kind", "team", "mode"});
    command.set_play =
        text(request, "kind", {"direct_free_kick", "indirect_free_kick", "penalty_kick", "corner_kick", "goal_kick", "throw_in"});
    command.team = game_team(request, status);
    if (request.contains("mode")) command.mode = whole(request, "mode", 0, 255);
  }
  return command;
}

Answer game_request(SimControl& control, const std::string& method, const std::string& body) {
  const std::optional<GameStatus> status = control.game();
  if (!status) return {404, error_body("no GameController here: /api/game is served by doppel (docs/gamecontroller.md)")};
  if (method == "GET") return {200, game_json(*status)};
  if (method != "POST") return {405, error_body("/api/game is read with GET and changed with POST")};
  try {
    const Outcome outcome = control.game_command(game_command(parse_object(body), *status));
    if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
  } catch (const Refused& refused) {
    return {refused.status, error_body(refused.message)};
  }
  const std::optional<GameStatus> after = control.game();
  return {200, after ? game_json(*after) : json(nullptr)};
}

// /api/teamcomm, /api/teamcomm/robots, /api/teamcomm/robots/TEAM/PLAYER.
Answer teamcomm_request(SimControl& control, const std::string& method, const std::string& action, const std::string& body) {
  const std::optional<TeamcommStatus> status = control.teamcomm();
  if (!status) return {404, error_body("no team-communication hub: doppel --teamcomm starts one (docs/teamcomm.md)")};
  try {
    if (action == "teamcomm") {
      if (method != "GET") return {405, error_body("/api/teamcomm is read with GET")};
      return {200, teamcomm_json(*status)};
    }
    if (action == "teamcomm/robots") {
      if (method == "GET") return {200, teamcomm_json(*status)["robots"]};
      if (method != "POST") return {405, error_body("/api/teamcomm/robots is read with GET and added to with POST")};
      const json request = parse_object(body);
      only_fields(request, {"team", "player", "port"});
      TeamcommRobot robot;
      robot.team = static_cast<int>(whole(request, "team", 0, 255));
      robot.player = static_cast<int>(whole(request, "player", 0, 255));
      robot.port = static_cast<uint16_t>(whole(request, "port", 1, 65535));
      const Outcome outcome = control.teamcomm_add(robot);
      if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
    } else {
      // teamcomm/robots/TEAM/PLAYER
      const std::string rest = action.substr(std::string("teamcomm/robots/").size());
      const auto slash = rest.find('/');
      const auto number = [](const std::string& part, const char* what) {
        if (part.empty() || part.size() > 3 || part.find_first_not_of("0123456789") != std::string::npos || std::stoi(part) > 255) {
          throw Refused{400, std::string(what) + " '" + part + "' in the path must be a number within 0..255"};
        }
        return std::stoi(part);
      };
      if (slash == std::string::npos) throw Refused{404, "no such path: /api/" + action + " (use /api/teamcomm/robots/TEAM/PLAYER)"};
      const int team = number(rest.substr(0, slash), "team");
      const int player = number(rest.substr(slash + 1), "player");
      if (method != "DELETE") return {405, error_body("/api/teamcomm/robots/TEAM/PLAYER is removed with DELETE")};
      const Outcome outcome = control.teamcomm_remove(team, player);
      if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
    }
  } catch (const Refused& refused) {
    return {refused.status, error_body(refused.message)};
  }
  const std::optional<TeamcommStatus> after = control.teamcomm();
  return {200, after ? teamcomm_json(*after) : json(nullptr)};
}

const char* scope_name(faults::FaultScope scope) {
  switch (scope) {
    case faults::FaultScope::kServo:
      return "servo";
    case faults::FaultScope::kBus:
      return "bus";
    case faults::FaultScope::kRobot:
      return "robot";
    case faults::FaultScope::kSensor:
      return "sensor";
  }
  return "";
}

// A whole number field within least..most, or `fallback` when absent.
int64_t optional_whole(const json& request, const std::string& field, int64_t least, int64_t most, int64_t fallback) {
  if (!request.contains(field)) return fallback;
  const json& value = request.at(field);
  if (!value.is_number_integer() && !value.is_number_unsigned()) throw Refused{400, "field '" + field + "' must be a whole number"};
  if (value.is_number_unsigned() && value.get<uint64_t>() > static_cast<uint64_t>(most)) {
    throw Refused{400, "field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most)};
  }
  const int64_t x = value.get<int64_t>();
  if (x < least || x > most) {
    throw Refused{400, "field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most) +
                           ", got " + std::to_string(x)};
  }
  return x;
}

// POST /api/faults: the fields of one fault, checked completely (types here, ranges and the
// kind's fields by faults::check) before anything is added.
faults::FaultSpec fault_spec(const json& request, const SimState& state) {
  if (!request.contains("kind")) throw Refused{400, "missing field 'kind' (one of " + faults::fault_kind_names() + ")"};
  const json& kind_value = request.at("kind");
  const std::optional<faults::FaultKind> kind =
      kind_value.is_string() ? faults::fault_kind(kind_value.get<std::string>()) : std::nullopt;
  if (!kind) throw Refused{400, "field 'kind' must be one of " + faults::fault_kind_names() + ", got " + kind_value.dump()};
  const faults::FaultKindInfo& info = faults::info(*kind);
  std::set<std::string> allowed = {"kind", "robot", "bus", "id", "start_s", "duration_s", "seed"};
  if (info.needs_rate) allowed.insert("rate");
  if (!info.value_field.empty()) allowed.insert(std::string(info.value_field));
  for (const auto& [key, value] : request.items()) {
    if (allowed.count(key) == 0) {
      throw Refused{400, "field '" + key + "' does not belong to kind " + std::string(info.name)};
    }
  }
  faults::FaultSpec spec;
  spec.kind = *kind;
  spec.robot = static_cast<uint32_t>(robot_index(request, state));
  spec.bus = static_cast<int32_t>(optional_whole(request, "bus", 0, 255, -1));
  spec.id = static_cast<int32_t>(optional_whole(request, "id", 0, 253, -1));
  if (request.contains("start_s")) {
    const double start = number(request, "start_s");
    if (start < 0.0 || start > faults::kMaxStartS) {
      throw Refused{400, "field 'start_s' must be within 0.." + json(faults::kMaxStartS).dump() + " s, got " + json(start).dump()};
    }
    spec.start_ns = std::llround(start * 1e9);
  }
  if (request.contains("duration_s")) {
    const double duration = number(request, "duration_s");
    const double most = static_cast<double>(faults::kMaxDurationNs) * 1e-9;
    if (duration < 0.0 || duration > most) {
      throw Refused{400, "field 'duration_s' must be within 0.." + json(most).dump() + " s (0: until cleared), got " +
                             json(duration).dump()};
    }
    spec.duration_ns = std::llround(duration * 1e9);
  }
  if (request.contains("seed")) {
    const json& seed = request.at("seed");
    if (!seed.is_number_unsigned() && !(seed.is_number_integer() && seed.get<int64_t>() >= 0)) {
      throw Refused{400, "field 'seed' must be a whole number >= 0"};
    }
    spec.seed = seed.get<uint64_t>();
  }
  if (info.needs_rate) spec.rate = number(request, "rate");
  if (!info.value_field.empty()) spec.value = number(request, std::string(info.value_field));
  if (const std::string problem = faults::check(spec); !problem.empty()) throw Refused{400, problem};
  return spec;
}

Answer faults_request(SimControl& control, const std::string& method, const std::string& action, const std::string& body) {
  if (!control.faults()) return {404, error_body("no faults here: /api/faults is served by a live doppel (docs/faults.md)")};
  try {
    std::optional<uint32_t> added;
    if (action == "faults") {
      if (method == "POST") {
        const faults::FaultSpec spec = fault_spec(parse_object(body), control.state());
        const FaultAnswer answer = control.add_fault(spec);
        if (answer.status != 200) return {answer.status, error_body(answer.error)};
        added = answer.number;
      } else if (method == "DELETE") {
        if (!body.empty()) only_fields(parse_object(body), {});
        const Outcome outcome = control.clear_faults();
        if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
      } else if (method != "GET") {
        return {405, error_body("/api/faults is read with GET, added to with POST and cleared with DELETE")};
      }
    } else {
      const std::string number = action.substr(std::string("faults/").size());
      if (number.empty() || number.size() > 9 || number.find_first_not_of("0123456789") != std::string::npos) {
        return {404, error_body("no such path: /api/" + action + " (/api/faults/N, N a fault's number)")};
      }
      if (method != "DELETE") return {405, error_body("/api/faults/N is cleared with DELETE")};
      const Outcome outcome = control.clear_fault(static_cast<uint32_t>(std::stoul(number)));
      if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
    }
    const std::optional<FaultList> list = control.faults();
    json out = list ? faults_json(*list) : json::object();
    if (added) out["added"] = *added;
    return {200, out};
  } catch (const Refused& refused) {
    return {refused.status, error_body(refused.message)};
  }
}

}  // namespace

json fault_json(const FaultEntry& entry) {
  const faults::Fault& f = entry.fault;
  const faults::FaultKindInfo& info = faults::info(f.spec.kind);
  json out = {{"number", f.number},
              {"kind", std::string(info.name)},
              {"scope", scope_name(info.scope)},
              {"robot", f.spec.robot},
              {"seed", f.spec.seed},
              {"start_s", static_cast<double>(f.start_ns) * 1e-9},
              {"active", entry.active},
              {"ended", entry.ended}};
  out["end_s"] = f.end_ns == INT64_MAX ? json(nullptr) : json(static_cast<double>(f.end_ns) * 1e-9);
  if (f.spec.bus >= 0) out["bus"] = f.spec.bus;
  if (f.spec.id >= 0) out["id"] = f.spec.id;
  if (info.needs_rate) out["rate"] = f.spec.rate;
  if (!info.value_field.empty()) out[std::string(info.value_field)] = f.spec.value;
  return out;
}

json faults_json(const FaultList& list) {
  json faults = json::array();
  for (const FaultEntry& entry : list.faults) faults.push_back(fault_json(entry));
  json kinds = json::array();
  for (const faults::FaultKindInfo& k : faults::fault_kinds()) {
    kinds.push_back({{"kind", std::string(k.name)},
                     {"scope", scope_name(k.scope)},
                     {"value_field", std::string(k.value_field)},
                     {"value_min", k.value_min},
                     {"value_max", k.value_max},
                     {"rate", k.needs_rate},
                     {"what", std::string(k.what)}});
  }
  return {{"sim_time_s", list.sim_time_s}, {"faults", faults}, {"kinds", kinds}};
}

json game_json(const GameStatus& status) {
  json teams = json::array();
  for (const GameTeam& team : status.teams) {
    json penalties = json::array();
    for (const GamePenalty& p : team.penalties) {
      penalties.push_back({{"player", p.player}, {"penalty", p.penalty}, {"reason", p.reason}, {"seconds_left", p.seconds_left}});
    }
    teams.push_back({{"number", team.number}, {"score", team.score}, {"penalties", penalties}});
  }
  json returns = json::array();
  for (const GameReturn& r : status.returns) {
    returns.push_back({{"team", r.team}, {"player", r.player}, {"message", r.message}, {"count", r.count}, {"age_s", r.age_s}});
  }
  json out = {{"on", status.on},
              {"sending", status.sending},
              {"stepped_aside", status.stepped_aside},
              {"destination", status.destination},
              {"return_address", status.return_address},
              {"watch", status.watch},
              {"watch_error", status.watch_error},
              {"state", status.state},
              {"first_half", status.first_half},
              {"kick_off_team", status.kick_off_team},
              {"secondary_state", status.secondary_state},
              {"secondary_team", status.secondary_team},
              {"secondary_mode", status.secondary_mode},
              {"secs_remaining", status.secs_remaining},
              {"packet_number", status.packet_number},
              {"sent", status.sent},
              {"teams", teams},
              {"returns", returns},
              {"bad_returns", status.bad_returns}};
  out["foreign"] = status.foreign ? json{{"from", status.foreign_from},
                                         {"packets", status.foreign_packets},
                                         {"state", status.foreign_state},
                                         {"teams", status.foreign_teams},
                                         {"scores", status.foreign_scores},
                                         {"age_s", status.foreign_age_s}}
                                  : json(nullptr);
  return out;
}

json teamcomm_json(const TeamcommStatus& status) {
  const auto robot = [](const TeamcommRobot& r) { return json{{"team", r.team}, {"player", r.player}, {"port", r.port}}; };
  json robots = json::array();
  for (const TeamcommRobot& r : status.robots) robots.push_back(robot(r));
  json links = json::array();
  for (const TeamcommLink& l : status.links) {
    links.push_back({{"from", robot(l.from)},
                     {"to", robot(l.to)},
                     {"relayed", l.relayed},
                     {"dropped", l.dropped},
                     {"delayed", l.delayed},
                     {"queue_full", l.queue_full},
                     {"send_errors", l.send_errors}});
  }
  return {{"listen", status.listen},     {"robot_address", status.robot_address}, {"loss", status.loss},
          {"delay_ms", status.delay_ms}, {"jitter_ms", status.jitter_ms},         {"received", status.received},
          {"unknown_sender", status.unknown_sender}, {"oversized", status.oversized}, {"robots", robots},
          {"links", links}};
}

json replay_json(const ReplayStatus& status) {
  return {{"start_s", status.start_s}, {"end_s", status.end_s}, {"position_s", status.position_s},
          {"speed", status.speed},     {"playing", status.playing}, {"cameras", status.cameras}};
}

json state_json(const SimState& state) {
  json robots = json::array();
  for (const RobotState& robot : state.robots) {
    json joints = json::object();
    for (const JointState& joint : robot.joints) joints[joint.name] = joint.position_rad;
    json imus = json::array();
    for (const ImuReading& imu : robot.imus) {
      imus.push_back({{"name", imu.name}, {"bus", imu.bus}, {"id", imu.id}, {"roll", imu.roll_rad}, {"pitch", imu.pitch_rad},
                      {"gyro", imu.gyro_rad_s}});
    }
    json feet = json::array();
    for (const FootReading& foot : robot.feet) {
      const double total = foot.force_n[0] + foot.force_n[1] + foot.force_n[2] + foot.force_n[3];
      feet.push_back({{"name", foot.name}, {"bus", foot.bus}, {"id", foot.id}, {"cells", foot.force_n}, {"total", total}});
    }
    json cameras = json::array();
    for (const CameraView& camera : robot.cameras) {
      cameras.push_back({{"name", camera.name}, {"p", camera.position}, {"q", camera.quaternion}, {"corners", camera.corner_rays}});
    }
    robots.push_back({{"name", robot.name},
                      {"simulated", robot.simulated},
                      {"pose", {{"x", robot.x_m}, {"y", robot.y_m}, {"z", robot.z_m}, {"yaw", robot.yaw_rad}}},
                      {"tilt", robot.tilt_rad},
                      {"fallen", robot.fallen},
                      {"held", robot.held},
                      {"joints", joints},
                      {"imus", imus},
                      {"feet", feet},
                      {"cameras", cameras}});
  }
  json out = {{"sim_time_s", state.sim_time_s}, {"paused", state.paused}, {"steps_left", state.steps_left},
              {"missed_ticks", state.missed_ticks},
              {"robots", robots}};
  out["ball"] = state.ball_m ? json{{"x", (*state.ball_m)[0]}, {"y", (*state.ball_m)[1]}, {"z", (*state.ball_m)[2]}} : json(nullptr);
  return out;
}

json scene_json(const Scene& scene) {
  json shapes = json::array();
  for (const SceneShape& shape : scene.shapes) {
    shapes.push_back({{"type", shape.type},
                      {"kind", shape.kind},
                      {"object", shape.object_id},
                      {"p", shape.position},
                      {"q", shape.quaternion},
                      {"size", shape.size},
                      {"rgb", shape.colour}});
    if (!shape.vertices.empty()) {
      shapes.back()["vertices"] = shape.vertices;
      shapes.back()["triangles"] = shape.triangles;
    }
  }
  return {{"sim_time_s", scene.sim_time_s}, {"shapes", shapes}};
}

json buses_json(const std::vector<BusTable>& buses) {
  json out = json::array();
  for (const BusTable& bus : buses) {
    json servos = json::array();
    for (const ServoRow& servo : bus.servos) {
      servos.push_back({{"id", servo.id},
                        {"name", servo.name},
                        {"model", servo.model},
                        {"torque", servo.torque},
                        {"goal_position", servo.goal_position},
                        {"present_position", servo.present_position},
                        {"present_speed", servo.present_speed},
                        {"present_load", servo.present_load},
                        {"temperature", servo.temperature},
                        {"voltage", servo.voltage},
                        {"error", servo.error >= 0 ? json(servo.error) : json(nullptr)}});
    }
    const BusCounters& c = bus.counters;
    const json counters = {{"packets", c.packets},
                           {"bad_checksums", c.bad_checksums},
                           {"replies", c.replies},
                           {"collisions", c.collisions},
                           {"dropped_replies", c.dropped_replies},
                           {"timeouts", c.timeouts},
                           {"late_deliveries", c.late_deliveries},
                           {"max_lateness_us", static_cast<double>(c.max_lateness_ns) * 1e-3},
                           {"bytes_in", c.bytes_in},
                           {"bytes_out", c.bytes_out},
                           {"connected", c.connected}};
    out.push_back({{"robot", bus.robot},
                   {"robot_name", bus.robot_name},
                   {"bus", bus.bus},
                   {"link", bus.link},
                   {"servos", servos},
                   {"counters", counters}});
  }
  return out;
}

Answer handle(SimControl& control, const std::string& method, const std::string& path, const std::string& body) {
  constexpr std::string_view kPrefix = "/api/";
  if (path.rfind(kPrefix, 0) != 0) return {404, error_body("no such path: " + path)};
  const std::string action = path.substr(kPrefix.size());
  if (action == "replay") return replay_request(control, method, body);
  if (action.rfind("robots/", 0) == 0 && action.size() > 19 && action.substr(action.size() - 12) == "/world_model") {
    return world_model_request(control, method, action, body);
  }
  if (action == "game") return game_request(control, method, body);
  if (action == "faults" || action.rfind("faults/", 0) == 0) return faults_request(control, method, action, body);
  if (action == "teamcomm" || action.rfind("teamcomm/robots", 0) == 0) return teamcomm_request(control, method, action, body);
  if (action == "analysis") {
    if (method != "GET") return {405, error_body("/api/analysis is read with GET")};
    const std::optional<std::string> analysis = control.bus_analysis();
    if (!analysis) {
      return {404, error_body("no bus analysis: /api/analysis is served by doppel-replay for a recording with bus "
                              "transactions (docs/analyzer.md)")};
    }
    json parsed = json::parse(*analysis, nullptr, false);
    if (parsed.is_discarded()) return {500, error_body("the bus analysis is not valid JSON")};
    return {200, std::move(parsed)};
  }
  if (action == "state" || action == "scene" || action == "buses") {
    if (method != "GET") return {405, error_body("/api/" + action + " is read with GET")};
    if (action == "scene") return {200, scene_json(control.scene())};
    if (action == "buses") return {200, buses_json(control.buses())};
    return {200, state_json(control.state())};
  }
  if (method != "POST") return {405, error_body("/api/" + action + " is a POST request")};
  try {
    const Outcome outcome = apply(control, action, parse_object(body));
    if (outcome.status != 200) return {outcome.status, error_body(outcome.error)};
    return {200, state_json(control.state())};
  } catch (const Refused& refused) {
    return {refused.status, error_body(refused.message)};
  }
}

StaticFiles default_static_files() {
  StaticFiles files;
  const char* viewer = std::getenv("DOPPEL_VIEWER_DIR");
  files.viewer_dir = viewer != nullptr && *viewer != '\0' ? viewer : DOPPEL_VIEWER_SOURCE_DIR;
  const char* three = std::getenv("DOPPEL_THREE_DIR");
  files.three_dir = three != nullptr && *three != '\0' ? three : "/usr/share/javascript/three";
  return files;
}

std::string static_files_problem(const StaticFiles& files) {
  if (!files.viewer_dir.empty() && !std::filesystem::is_regular_file(std::filesystem::path(files.viewer_dir) / "index.html")) {
    return "the viewer's folder " + files.viewer_dir + " has no index.html (--viewer-dir or DOPPEL_VIEWER_DIR names it)";
  }
  if (!files.three_dir.empty() && !std::filesystem::is_regular_file(std::filesystem::path(files.three_dir) / "three.min.js")) {
    return "three.js is not at " + files.three_dir +
           "/three.min.js (install Debian's libjs-three: scripts/setup; DOPPEL_THREE_DIR names another folder)";
  }
  return "";
}

HttpApi::HttpApi(SimControl& control, const std::string& address, uint16_t port, const StaticFiles& files,
                 std::string token)
    : control_(control), address_(address), server_(std::make_unique<httplib::Server>()) {
  // The viewer: its page at /, three.js at /three/. Files only; the API answers JSON below.
  if (const std::string problem = static_files_problem(files); !problem.empty()) throw std::runtime_error(problem);
  if (!files.viewer_dir.empty()) server_->set_mount_point("/", files.viewer_dir);
  if (!files.three_dir.empty()) server_->set_mount_point("/three", files.three_dir);
  server_->set_payload_max_length(64 * 1024);
  // The library's default also sets SO_REUSEPORT, which lets a second doppel share the port
  // unnoticed (and receive half of the requests): only SO_REUSEADDR here.
  server_->set_socket_options([](int socket) {
    const int yes = 1;
    ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  // Every request, files and API alike, before routing: Host, Origin, Content-Type and the token
  // (control/access.h). Endpoints added later are covered without a line of their own.
  server_->set_pre_routing_handler([this](const httplib::Request& request, httplib::Response& response) {
    RequestHeaders headers;
    headers.method = request.method;
    headers.path = request.path;
    headers.host = request.get_header_value("Host");
    headers.origin = request.get_header_value("Origin");
    headers.content_type = request.get_header_value("Content-Type");
    headers.authorization = request.get_header_value("Authorization");
    headers.doppel_token = request.get_header_value("X-Doppel-Token");
    headers.cookie = request.get_header_value("Cookie");
    headers.query_token = request.get_param_value("token");
    const AccessVerdict verdict = check_access(policy_, headers);
    if (verdict.status != 200) {
      response.status = verdict.status;
      response.set_header("Connection", "close");  // an unread body must not be taken for the next request
      response.set_content(error_body(verdict.error).dump(), "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (verdict.set_cookie) {
      response.set_header("Set-Cookie", token_cookie_name(policy_.port) + "=" + policy_.token +
                                            "; Path=/; HttpOnly; SameSite=Strict");
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  auto serve = [this](const httplib::Request& request, httplib::Response& response) {
    const Answer answer = handle(control_, request.method, request.path, request.body);
    response.status = answer.status;
    response.set_content(answer.body.dump(), "application/json");
  };
  // A camera's latest still as PNG (the only answer that is not JSON, unless it is an error).
  server_->Get(R"(/api/camera/(.+))", [this](const httplib::Request& request, httplib::Response& response) {
    const CameraStill still = control_.camera_still(request.matches[1]);
    response.status = still.status;
    if (still.status != 200) {
      response.set_content(error_body(still.error).dump(), "application/json");
      return;
    }
    response.set_header("Cache-Control", "no-store");
    response.set_header("X-Sim-Time", std::to_string(still.sim_time_s));
    // A replay serves the still as recorded: PNG, or JPEG (its magic bytes FF D8 FF).
    const bool jpeg = still.png.size() >= 3 && static_cast<uint8_t>(still.png[0]) == 0xFF &&
                      static_cast<uint8_t>(still.png[1]) == 0xD8 && static_cast<uint8_t>(still.png[2]) == 0xFF;
    response.set_content(still.png, jpeg ? "image/jpeg" : "image/png");
  });
  server_->Get(R"(/api/.*)", serve);
  server_->Post(R"(/api/.*)", serve);
  server_->Put(R"(/api/.*)", serve);
  server_->Delete(R"(/api/.*)", serve);
  if (port == 0) {
    const int bound = server_->bind_to_any_port(address);
    if (bound <= 0) throw std::runtime_error("cannot listen on " + address + " (any port)");
    port_ = static_cast<uint16_t>(bound);
  } else {
    if (!server_->bind_to_port(address, port)) {
      throw std::runtime_error("cannot listen on " + address + ":" + std::to_string(port) +
                               " (in use by another program, another doppel, or not an address of this machine)");
    }
    port_ = port;
  }
  policy_ = access_policy(address, port_, std::move(token));
}

HttpApi::~HttpApi() { stop(); }

void HttpApi::start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  // stop() can only end a server that is already listening.
  while (!server_->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void HttpApi::stop() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace doppel::control
