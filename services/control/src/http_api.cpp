#include "control/http_api.h"

#include <httplib.h>
#include <sys/socket.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <set>
#include <stdexcept>

namespace doppel::control {
namespace {

using contract::Error;
using contract::ErrorKind;
using nlohmann::json;

json error_body(const std::string& message) { return json{{"error", message}}; }

// An answer that refuses: an HTTP-only status (405, 500) with its message, or a domain error mapped.
Answer refusal(int status, const std::string& message) { return {status, error_body(message)}; }
Answer refusal(const Error& error) { return {http_status(error.kind), error_body(error.message)}; }

// The checks of one request's JSON body. The first check that fails keeps its Error and every later
// one does nothing (returning a neutral value), so a handler runs its checks in order and looks at
// failed() once before it asks the host anything: all fields are checked before any applies.
class Fields {
 public:
  // The body: a JSON object, or empty (no fields).
  explicit Fields(const std::string& body) : request_(json::object()) {
    if (body.empty()) return;
    request_ = json::parse(body, nullptr, false);
    if (request_.is_discarded()) {
      refuse("the request body is not JSON");
    } else if (!request_.is_object()) {
      refuse("the request body must be a JSON object");
    }
  }

  bool failed() const noexcept { return error_.has_value(); }
  const Error& error() const { return *error_; }
  // The request's error unless an earlier check failed already.
  void refuse(std::string message, ErrorKind kind = ErrorKind::kInvalid) {
    if (!error_) error_ = Error{kind, std::move(message)};
  }
  bool has(const std::string& field) const { return !failed() && request_.contains(field); }
  bool none() const { return !failed() && request_.empty(); }
  const json& at(const std::string& field) const { return request_.at(field); }

  // No field but these; `kind`: the fault kind they were chosen for, named in the refusal.
  void only(const std::set<std::string>& allowed, std::string_view kind = {}) {
    if (failed()) return;
    for (const auto& [key, value] : request_.items()) {
      if (allowed.count(key) != 0) continue;
      return refuse(kind.empty() ? "unknown field '" + key + "'"
                                 : "field '" + key + "' does not belong to kind " + std::string(kind));
    }
  }

  double number(const std::string& field) {
    if (failed()) return 0.0;
    if (!request_.contains(field)) return refuse("missing field '" + field + "'"), 0.0;
    const json& value = request_.at(field);
    if (!value.is_number()) return refuse("field '" + field + "' must be a number"), 0.0;
    const double x = value.get<double>();
    if (!std::isfinite(x)) return refuse("field '" + field + "' must be finite"), 0.0;
    return x;
  }

  uint32_t whole(const std::string& field, uint32_t least, uint32_t most) {
    if (failed()) return least;
    if (!request_.contains(field)) return refuse("missing field '" + field + "'"), least;
    const json& value = request_.at(field);
    if (!value.is_number_integer() && !value.is_number_unsigned()) {
      return refuse("field '" + field + "' must be a whole number"), least;
    }
    const int64_t x = value.get<int64_t>();
    if (x < least || x > most) {
      refuse("field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most) + ", got " +
             std::to_string(x));
      return least;
    }
    return static_cast<uint32_t>(x);
  }

  // A whole number field within least..most, or `fallback` when absent.
  int64_t optional_whole(const std::string& field, int64_t least, int64_t most, int64_t fallback) {
    if (!has(field)) return fallback;
    const json& value = request_.at(field);
    if (!value.is_number_integer() && !value.is_number_unsigned()) {
      return refuse("field '" + field + "' must be a whole number"), fallback;
    }
    if (value.is_number_unsigned() && value.get<uint64_t>() > static_cast<uint64_t>(most)) {
      return refuse("field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most)), fallback;
    }
    const int64_t x = value.get<int64_t>();
    if (x < least || x > most) {
      refuse("field '" + field + "' must be within " + std::to_string(least) + ".." + std::to_string(most) + ", got " +
             std::to_string(x));
      return fallback;
    }
    return x;
  }

  std::string text(const std::string& field, const std::set<std::string>& allowed) {
    if (failed()) return "";
    if (!request_.contains(field)) return refuse("missing field '" + field + "'"), "";
    const json& value = request_.at(field);
    if (!value.is_string() || allowed.count(value.get<std::string>()) == 0) {
      std::string names;
      for (const std::string& name : allowed) names += (names.empty() ? "" : ", ") + name;
      return refuse("field '" + field + "' must be one of " + names + ", got " + value.dump()), "";
    }
    return value.get<std::string>();
  }

  // Optional fields: `to` keeps its value when the field is absent.
  void flag(const std::string& field, bool& to) {
    if (!has(field)) return;
    if (!request_.at(field).is_boolean()) return refuse("field '" + field + "' must be true or false");
    to = request_.at(field).get<bool>();
  }
  void real(const std::string& field, double& to) {
    if (has(field)) to = number(field);
  }
  void seed(const std::string& field, uint64_t& to) {
    if (!has(field)) return;
    const json& value = request_.at(field);
    if (!value.is_number_unsigned() && !(value.is_number_integer() && value.get<int64_t>() >= 0)) {
      return refuse("field '" + field + "' must be a whole number >= 0");
    }
    to = value.get<uint64_t>();
  }

 private:
  json request_;
  std::optional<Error> error_;
};

std::size_t robot_index(Fields& fields, const contract::SimState& state) {
  if (fields.failed()) return 0;
  if (!fields.has("robot")) return fields.refuse("missing field 'robot' (a robot's index or name)"), 0;
  const json& robot = fields.at("robot");
  if (robot.is_number_integer() || robot.is_number_unsigned()) {
    const int64_t index = robot.get<int64_t>();
    if (index < 0 || static_cast<std::size_t>(index) >= state.robots.size()) {
      fields.refuse("no robot " + std::to_string(index) + " (there are " + std::to_string(state.robots.size()) + ")",
                    ErrorKind::kNotFound);
      return 0;
    }
    return static_cast<std::size_t>(index);
  }
  if (!robot.is_string()) return fields.refuse("field 'robot' must be a robot's index or name"), 0;
  const std::string name = robot.get<std::string>();
  std::optional<std::size_t> found;
  for (std::size_t r = 0; r < state.robots.size(); ++r) {
    if (state.robots[r].name != name) continue;
    if (found) return fields.refuse("two robots are named '" + name + "': give its index"), 0;
    found = r;
  }
  if (!found) return fields.refuse("no robot named '" + name + "'", ErrorKind::kNotFound), 0;
  return *found;
}

void on_carpet(Fields& fields, const contract::SimState& state, double x, double y) {
  if (fields.failed()) return;
  if (std::abs(x) > state.carpet_half_length_m || std::abs(y) > state.carpet_half_width_m) {
    fields.refuse("(" + json(x).dump() + ", " + json(y).dump() + ") is off the carpet (|x| <= " +
                  json(state.carpet_half_length_m).dump() + ", |y| <= " + json(state.carpet_half_width_m).dump() + " m)");
  }
}

void simulated(Fields& fields, const contract::SimState& state, std::size_t robot) {
  if (fields.failed() || state.robots[robot].simulated) return;
  fields.refuse("robot " + std::to_string(robot) + " '" + state.robots[robot].name +
                    "' has no body in the world (no figure, or --physics none)",
                ErrorKind::kConflict);
}

// What the route's pattern captured and the request's method and body.
struct Call {
  const std::string& method;
  const std::smatch& path;  // [0] the whole path, [1].. the pattern's groups
  const std::string& body;
};

contract::Outcome apply(contract::Simulation& simulation, const std::string& action, Fields& fields) {
  if (action == "pause" || action == "resume" || action == "reset") {
    fields.only({});
    if (fields.failed()) return fields.error();
    return action == "pause" ? simulation.pause() : action == "resume" ? simulation.resume() : simulation.reset();
  }
  if (action == "step") {
    fields.only({"ms"});
    const uint32_t ms = fields.whole("ms", 1, kMaxStepMs);
    if (fields.failed()) return fields.error();
    return simulation.step(ms);
  }
  const contract::SimState state = simulation.state();
  if (action == "place") {
    fields.only({"robot", "x", "y", "yaw"});
    const std::size_t robot = robot_index(fields, state);
    const double x = fields.number("x"), y = fields.number("y"), yaw = fields.number("yaw");
    on_carpet(fields, state, x, y);
    simulated(fields, state, robot);
    if (fields.failed()) return fields.error();
    return simulation.place(robot, x, y, yaw);
  }
  if (action == "push") {
    fields.only({"robot", "fx", "fy", "fz", "ms"});
    const std::size_t robot = robot_index(fields, state);
    const double fx = fields.number("fx"), fy = fields.number("fy"), fz = fields.number("fz");
    if (!fields.failed() && std::sqrt(fx * fx + fy * fy + fz * fz) > kMaxPushForceN) {
      fields.refuse("a push of more than " + std::to_string(static_cast<int>(kMaxPushForceN)) + " N is refused");
    }
    const uint32_t ms = fields.whole("ms", 1, kMaxPushMs);
    simulated(fields, state, robot);
    if (fields.failed()) return fields.error();
    return simulation.push(robot, fx, fy, fz, ms);
  }
  // ball (the route names no other action)
  fields.only({"x", "y"});
  const double x = fields.number("x"), y = fields.number("y");
  if (!fields.failed() && !state.ball_m) {
    fields.refuse("there is no ball (no world: --physics none or no robot with a body)", ErrorKind::kConflict);
  }
  on_carpet(fields, state, x, y);
  if (fields.failed()) return fields.error();
  return simulation.ball(x, y);
}

// POST /api/pause, resume, reset, step, place, push, ball: checked, applied, the state afterwards.
Answer simulation_request(const contract::Facets& host, const Call& call) {
  const std::string action = call.path[1];
  if (call.method != "POST") return refusal(405, "/api/" + action + " is a POST request");
  Fields fields(call.body);
  if (const contract::Outcome outcome = apply(*host.simulation, action, fields); !outcome.ok()) return refusal(outcome.error());
  return {200, state_json(host.simulation->state())};
}

// GET /api/state, /api/scene, /api/buses.
Answer reading_request(const contract::Facets& host, const Call& call) {
  const std::string what = call.path[1];
  if (call.method != "GET") return refusal(405, "/api/" + what + " is read with GET");
  if (what == "scene") return {200, scene_json(host.simulation->scene())};
  if (what == "buses") return {200, buses_json(host.simulation->buses())};
  return {200, state_json(host.simulation->state())};
}

// Any other /api/ path.
Answer unknown_request(const contract::Facets&, const Call& call) {
  const std::string action = call.path[1];
  if (call.method != "POST") return refusal(405, "/api/" + action + " is a POST request");
  const Fields fields(call.body);
  if (fields.failed()) return refusal(fields.error());
  return refusal(404, "no such request: /api/" + action);
}

// The checked fields of POST /api/replay against the replay's `status`: all or nothing.
contract::ReplayChange replay_change(Fields& fields, const contract::ReplayStatus& status) {
  fields.only({"position_s", "speed", "playing"});
  if (fields.none()) fields.refuse("give at least one of 'position_s', 'speed', 'playing'");
  contract::ReplayChange change;
  if (fields.has("position_s")) {
    const double position = fields.number("position_s");
    if (!fields.failed() && (position < status.start_s || position > status.end_s)) {
      fields.refuse("field 'position_s' must be within " + json(status.start_s).dump() + ".." + json(status.end_s).dump() +
                    " s (the recording), got " + json(position).dump());
    }
    change.position_s = position;
  }
  if (fields.has("speed")) {
    const double speed = fields.number("speed");
    if (!fields.failed() && (speed < contract::kMinReplaySpeed || speed > contract::kMaxReplaySpeed)) {
      fields.refuse("field 'speed' must be within " + json(contract::kMinReplaySpeed).dump() + ".." +
                    json(contract::kMaxReplaySpeed).dump() + ", got " + json(speed).dump());
    }
    change.speed = speed;
  }
  if (fields.has("playing")) {
    bool playing = false;
    fields.flag("playing", playing);
    change.playing = playing;
  }
  return change;
}

Answer replay_request(const contract::Facets& host, const Call& call) {
  if (host.replay == nullptr) return refusal(404, "this is not a replay: /api/replay is served by doppel-replay (docs/replay.md)");
  const contract::ReplayStatus status = host.replay->replay();
  if (call.method == "GET") return {200, replay_json(status)};
  if (call.method != "POST") return refusal(405, "/api/replay is read with GET and changed with POST");
  Fields fields(call.body);
  const contract::ReplayChange change = replay_change(fields, status);
  if (fields.failed()) return refusal(fields.error());
  if (const contract::Outcome outcome = host.replay->change_replay(change); !outcome.ok()) return refusal(outcome.error());
  return {200, replay_json(host.replay->replay())};
}

Answer analysis_request(const contract::Facets& host, const Call& call) {
  if (call.method != "GET") return refusal(405, "/api/analysis is read with GET");
  const std::optional<std::string> analysis = host.replay != nullptr ? host.replay->bus_analysis() : std::nullopt;
  if (!analysis) {
    return refusal(404, "no bus analysis: /api/analysis is served by doppel-replay for a recording with bus "
                        "transactions (docs/analyzer.md)");
  }
  json parsed = json::parse(*analysis, nullptr, false);
  if (parsed.is_discarded()) return refusal(500, "the bus analysis is not valid JSON");
  return {200, std::move(parsed)};
}

// GET/PUT /api/robots/N/world_model: a robot's world-model sensor settings; PUT changes the fields
// it names (the others stay), each checked for its type here and for its range by the sensor.
Answer world_model_request(const contract::Facets& host, const Call& call) {
  const std::string index = call.path[1];
  if (index.size() > 6 || index.find_first_not_of("0123456789") != std::string::npos) {
    return refusal(404, "no such path: " + call.path.str(0) + " (/api/robots/N/world_model, N a robot's index)");
  }
  if (call.method != "GET" && call.method != "PUT") {
    return refusal(405, "/api/robots/N/world_model is read with GET and changed with PUT");
  }
  if (host.world_model == nullptr) return refusal(404, "no world-model sensor in this simulation (doppel --world-model)");
  const auto robot = static_cast<std::size_t>(std::stoul(index));
  contract::Result<contract::WorldModelSettings> answer = host.world_model->world_model(robot);
  if (answer.ok() && call.method == "PUT") {
    Fields fields(call.body);
    fields.only({"enabled", "rate_hz", "fov_deg", "max_range_m", "nearest_ball_only", "position_sigma_m", "angle_sigma_rad",
                 "dropout", "latency_s", "seed"});
    contract::WorldModelSettings settings = answer.value();
    fields.flag("enabled", settings.enabled);
    fields.flag("nearest_ball_only", settings.nearest_ball_only);
    fields.real("rate_hz", settings.rate_hz);
    fields.real("fov_deg", settings.fov_deg);
    fields.real("max_range_m", settings.max_range_m);
    fields.real("position_sigma_m", settings.position_sigma_m);
    fields.real("angle_sigma_rad", settings.angle_sigma_rad);
    fields.real("dropout", settings.dropout);
    fields.real("latency_s", settings.latency_s);
    fields.seed("seed", settings.seed);
    if (fields.failed()) return refusal(fields.error());
    answer = host.world_model->set_world_model(robot, settings);
  }
  if (!answer.ok()) return refusal(answer.error());
  const contract::WorldModelSettings& s = answer.value();
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
int game_team(Fields& fields, const contract::GameStatus& status, bool drop_ball_allowed = false) {
  if (fields.failed()) return 0;
  if (!fields.has("team")) return fields.refuse("missing field 'team' (A, B or a team number)"), 0;
  const json& team = fields.at("team");
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
  fields.refuse("field 'team' must be A, B or a team number of this game (" + std::to_string(status.teams[0].number) + ", " +
                std::to_string(status.teams[1].number) + ")" + (drop_ball_allowed ? " or drop_ball" : "") + ", got " +
                team.dump());
  return 0;
}

contract::GameCommand game_command(Fields& fields, const contract::GameStatus& status) {
  contract::GameCommand command;
  command.command = fields.text("command", {"on", "off", "state", "goal", "score", "kickoff", "penalize", "unpenalize",
                                            "set_play", "timeout", "normal"});
  if (fields.failed()) return command;
  const std::string& c = command.command;
  if (c == "on" || c == "off" || c == "normal") {
    fields.only({"command"});
  } else if (c == "state") {
    fields.only({"command", "state"});
    command.state = fields.text("state", {"initial", "ready", "set", "playing", "finished"});
  } else if (c == "goal" || c == "timeout") {
    fields.only({"command", "team"});
    command.team = game_team(fields, status);
  } else if (c == "score") {
    fields.only({"command", "team", "score"});
    command.team = game_team(fields, status);
    command.score = fields.whole("score", 0, 255);
  } else if (c == "kickoff") {
    fields.only({"command", "team"});
    command.team = game_team(fields, status, true);
  } else if (c == "penalize" || c == "unpenalize") {
    fields.only(c == "penalize" ? std::set<std::string>{"command", "team", "player", "seconds", "reason"}
                                : std::set<std::string>{"command", "team", "player"});
    command.team = game_team(fields, status);
    command.player = fields.whole("player", 1, kMaxGamePlayers);
    if (c == "penalize") {
      if (fields.has("seconds")) command.seconds = fields.whole("seconds", 0, 255);
      if (fields.has("reason")) {
        std::set<std::string> names;
        for (const contract::GamePenaltyName& penalty : contract::kGamePenalties) names.insert(penalty.name);
        const std::string reason = fields.text("reason", names);
        for (const contract::GamePenaltyName& penalty : contract::kGamePenalties) {
          if (reason == penalty.name) command.penalty = penalty.code;
        }
      }
    }
  } else {  // set_play
    fields.only({"command", "kind", "team", "mode"});
    command.set_play =
        fields.text("kind", {"direct_free_kick", "indirect_free_kick", "penalty_kick", "corner_kick", "goal_kick", "throw_in"});
    command.team = game_team(fields, status);
    if (fields.has("mode")) command.mode = fields.whole("mode", 0, 255);
  }
  return command;
}

Answer game_request(const contract::Facets& host, const Call& call) {
  if (host.game == nullptr) return refusal(404, "no GameController here: /api/game is served by doppel (docs/gamecontroller.md)");
  const contract::GameStatus status = host.game->game();
  if (call.method == "GET") return {200, game_json(status)};
  if (call.method != "POST") return refusal(405, "/api/game is read with GET and changed with POST");
  Fields fields(call.body);
  const contract::GameCommand command = game_command(fields, status);
  if (fields.failed()) return refusal(fields.error());
  if (const contract::Outcome outcome = host.game->game_command(command); !outcome.ok()) return refusal(outcome.error());
  return {200, game_json(host.game->game())};
}

// The hub, or why there is none.
std::optional<contract::TeamcommStatus> teamcomm_status(const contract::Facets& host) {
  return host.teamcomm != nullptr ? host.teamcomm->teamcomm() : std::nullopt;
}
const char* const kNoHub = "no team-communication hub: doppel --teamcomm starts one (docs/teamcomm.md)";

Answer teamcomm_answer(const contract::Facets& host) {
  const std::optional<contract::TeamcommStatus> after = teamcomm_status(host);
  return {200, after ? teamcomm_json(*after) : json(nullptr)};
}

// GET /api/teamcomm.
Answer teamcomm_request(const contract::Facets& host, const Call& call) {
  const std::optional<contract::TeamcommStatus> status = teamcomm_status(host);
  if (!status) return refusal(404, kNoHub);
  if (call.method != "GET") return refusal(405, "/api/teamcomm is read with GET");
  return {200, teamcomm_json(*status)};
}

// GET, POST /api/teamcomm/robots.
Answer teamcomm_robots_request(const contract::Facets& host, const Call& call) {
  const std::optional<contract::TeamcommStatus> status = teamcomm_status(host);
  if (!status) return refusal(404, kNoHub);
  if (call.method == "GET") return {200, teamcomm_json(*status)["robots"]};
  if (call.method != "POST") return refusal(405, "/api/teamcomm/robots is read with GET and added to with POST");
  Fields fields(call.body);
  fields.only({"team", "player", "port"});
  contract::TeamcommRobot robot;
  robot.team = static_cast<int>(fields.whole("team", 0, 255));
  robot.player = static_cast<int>(fields.whole("player", 0, 255));
  robot.port = static_cast<uint16_t>(fields.whole("port", 1, 65535));
  if (fields.failed()) return refusal(fields.error());
  if (const contract::Outcome outcome = host.teamcomm->teamcomm_add(robot); !outcome.ok()) return refusal(outcome.error());
  return teamcomm_answer(host);
}

// DELETE /api/teamcomm/robots/TEAM/PLAYER.
Answer teamcomm_robot_request(const contract::Facets& host, const Call& call) {
  if (!teamcomm_status(host)) return refusal(404, kNoHub);
  int numbers[2] = {0, 0};
  const char* const what[2] = {"team", "player"};
  for (int i = 0; i < 2; ++i) {
    const std::string part = call.path[i + 1];
    if (part.empty() || part.size() > 3 || part.find_first_not_of("0123456789") != std::string::npos || std::stoi(part) > 255) {
      return refusal(400, std::string(what[i]) + " '" + part + "' in the path must be a number within 0..255");
    }
    numbers[i] = std::stoi(part);
  }
  if (call.method != "DELETE") return refusal(405, "/api/teamcomm/robots/TEAM/PLAYER is removed with DELETE");
  if (const contract::Outcome outcome = host.teamcomm->teamcomm_remove(numbers[0], numbers[1]); !outcome.ok()) {
    return refusal(outcome.error());
  }
  return teamcomm_answer(host);
}

// Any other /api/teamcomm/robots... path.
Answer teamcomm_path_request(const contract::Facets& host, const Call& call) {
  if (!teamcomm_status(host)) return refusal(404, kNoHub);
  return refusal(404, "no such path: " + call.path.str(0) + " (use /api/teamcomm/robots/TEAM/PLAYER)");
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

// POST /api/faults: the fields of one fault, checked completely (types here, ranges and the
// kind's fields by faults::check) before anything is added.
faults::FaultSpec fault_spec(Fields& fields, const contract::SimState& state) {
  faults::FaultSpec spec;
  if (fields.failed()) return spec;
  if (!fields.has("kind")) return fields.refuse("missing field 'kind' (one of " + faults::fault_kind_names() + ")"), spec;
  const json& kind_value = fields.at("kind");
  const std::optional<faults::FaultKind> kind =
      kind_value.is_string() ? faults::fault_kind(kind_value.get<std::string>()) : std::nullopt;
  if (!kind) {
    return fields.refuse("field 'kind' must be one of " + faults::fault_kind_names() + ", got " + kind_value.dump()), spec;
  }
  const faults::FaultKindInfo& info = faults::info(*kind);
  std::set<std::string> allowed = {"kind", "robot", "bus", "id", "start_s", "duration_s", "seed"};
  if (info.needs_rate) allowed.insert("rate");
  if (!info.value_field.empty()) allowed.insert(std::string(info.value_field));
  fields.only(allowed, info.name);
  spec.kind = *kind;
  spec.robot = static_cast<uint32_t>(robot_index(fields, state));
  spec.bus = static_cast<int32_t>(fields.optional_whole("bus", 0, 255, -1));
  spec.id = static_cast<int32_t>(fields.optional_whole("id", 0, 253, -1));
  if (fields.has("start_s")) {
    const double start = fields.number("start_s");
    if (!fields.failed() && (start < 0.0 || start > faults::kMaxStartS)) {
      fields.refuse("field 'start_s' must be within 0.." + json(faults::kMaxStartS).dump() + " s, got " + json(start).dump());
    }
    spec.start_ns = std::llround(start * 1e9);
  }
  if (fields.has("duration_s")) {
    const double duration = fields.number("duration_s");
    const double most = static_cast<double>(faults::kMaxDurationNs) * 1e-9;
    if (!fields.failed() && (duration < 0.0 || duration > most)) {
      fields.refuse("field 'duration_s' must be within 0.." + json(most).dump() + " s (0: until cleared), got " +
                    json(duration).dump());
    }
    spec.duration_ns = std::llround(duration * 1e9);
  }
  fields.seed("seed", spec.seed);
  if (info.needs_rate) spec.rate = fields.number("rate");
  if (!info.value_field.empty()) spec.value = fields.number(std::string(info.value_field));
  if (fields.failed()) return spec;
  if (const std::string problem = faults::check(spec); !problem.empty()) fields.refuse(problem);
  return spec;
}

const char* const kNoFaults = "no faults here: /api/faults is served by a live doppel (docs/faults.md)";

Answer faults_answer(const contract::Facets& host, std::optional<uint32_t> added = std::nullopt) {
  json out = faults_json(host.faults->faults());
  if (added) out["added"] = *added;
  return {200, out};
}

// GET, POST, DELETE /api/faults.
Answer faults_request(const contract::Facets& host, const Call& call) {
  if (host.faults == nullptr) return refusal(404, kNoFaults);
  if (call.method == "POST") {
    Fields fields(call.body);
    const faults::FaultSpec spec = fault_spec(fields, host.simulation->state());
    if (fields.failed()) return refusal(fields.error());
    const contract::Result<uint32_t> added = host.faults->add_fault(spec);
    if (!added.ok()) return refusal(added.error());
    return faults_answer(host, added.value());
  }
  if (call.method == "DELETE") {
    Fields fields(call.body);
    fields.only({});
    if (fields.failed()) return refusal(fields.error());
    if (const contract::Outcome outcome = host.faults->clear_faults(); !outcome.ok()) return refusal(outcome.error());
  } else if (call.method != "GET") {
    return refusal(405, "/api/faults is read with GET, added to with POST and cleared with DELETE");
  }
  return faults_answer(host);
}

// DELETE /api/faults/N.
Answer fault_request(const contract::Facets& host, const Call& call) {
  if (host.faults == nullptr) return refusal(404, kNoFaults);
  const std::string number = call.path[1];
  if (number.empty() || number.size() > 9 || number.find_first_not_of("0123456789") != std::string::npos) {
    return refusal(404, "no such path: " + call.path.str(0) + " (/api/faults/N, N a fault's number)");
  }
  if (call.method != "DELETE") return refusal(405, "/api/faults/N is cleared with DELETE");
  if (const contract::Outcome outcome = host.faults->clear_fault(static_cast<uint32_t>(std::stoul(number))); !outcome.ok()) {
    return refusal(outcome.error());
  }
  return faults_answer(host);
}

// Every /api/ request by its path, first match wins. The patterns are cpp-httplib's (a regular
// expression over the whole path, its groups in Request::matches), so that the server and handle()
// route alike.
struct Route {
  const char* pattern;
  Answer (*serve)(const contract::Facets& host, const Call& call);
};
constexpr Route kRoutes[] = {
    {R"(/api/(state|scene|buses))", reading_request},
    {R"(/api/(pause|resume|reset|step|place|push|ball))", simulation_request},
    {R"(/api/replay)", replay_request},
    {R"(/api/analysis)", analysis_request},
    {R"(/api/robots/(.+)/world_model)", world_model_request},
    {R"(/api/game)", game_request},
    {R"(/api/teamcomm)", teamcomm_request},
    {R"(/api/teamcomm/robots)", teamcomm_robots_request},
    {R"(/api/teamcomm/robots/([^/]*)/(.*))", teamcomm_robot_request},
    {R"(/api/teamcomm/robots.+)", teamcomm_path_request},
    {R"(/api/faults)", faults_request},
    {R"(/api/faults/(.*))", fault_request},
    {R"(/api/(.*))", unknown_request},
};

}  // namespace

int http_status(contract::ErrorKind kind) noexcept {
  switch (kind) {
    case ErrorKind::kInvalid:
      return 400;
    case ErrorKind::kNotFound:
      return 404;
    case ErrorKind::kConflict:
      return 409;
    case ErrorKind::kUnavailable:
      return 503;
  }
  return 500;
}

json fault_json(const contract::FaultEntry& entry) {
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

json faults_json(const contract::FaultList& list) {
  json faults = json::array();
  for (const contract::FaultEntry& entry : list.faults) faults.push_back(fault_json(entry));
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

json game_json(const contract::GameStatus& status) {
  json teams = json::array();
  for (const contract::GameTeam& team : status.teams) {
    json penalties = json::array();
    for (const contract::GamePenalty& p : team.penalties) {
      penalties.push_back({{"player", p.player}, {"penalty", p.penalty}, {"reason", p.reason}, {"seconds_left", p.seconds_left}});
    }
    teams.push_back({{"number", team.number}, {"score", team.score}, {"penalties", penalties}});
  }
  json returns = json::array();
  for (const contract::GameReturn& r : status.returns) {
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

json teamcomm_json(const contract::TeamcommStatus& status) {
  const auto robot = [](const contract::TeamcommRobot& r) { return json{{"team", r.team}, {"player", r.player}, {"port", r.port}}; };
  json robots = json::array();
  for (const contract::TeamcommRobot& r : status.robots) robots.push_back(robot(r));
  json links = json::array();
  for (const contract::TeamcommLink& l : status.links) {
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

json replay_json(const contract::ReplayStatus& status) {
  return {{"start_s", status.start_s}, {"end_s", status.end_s}, {"position_s", status.position_s},
          {"speed", status.speed},     {"playing", status.playing}, {"cameras", status.cameras}};
}

json state_json(const contract::SimState& state) {
  json robots = json::array();
  for (const contract::RobotState& robot : state.robots) {
    json joints = json::object();
    for (const contract::JointState& joint : robot.joints) joints[joint.name] = joint.position_rad;
    json imus = json::array();
    for (const contract::ImuReading& imu : robot.imus) {
      imus.push_back({{"name", imu.name}, {"bus", imu.bus}, {"id", imu.id}, {"roll", imu.roll_rad}, {"pitch", imu.pitch_rad},
                      {"gyro", imu.gyro_rad_s}});
    }
    json feet = json::array();
    for (const contract::FootReading& foot : robot.feet) {
      const double total = foot.force_n[0] + foot.force_n[1] + foot.force_n[2] + foot.force_n[3];
      feet.push_back({{"name", foot.name}, {"bus", foot.bus}, {"id", foot.id}, {"cells", foot.force_n}, {"total", total}});
    }
    json cameras = json::array();
    for (const contract::CameraView& camera : robot.cameras) {
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

json scene_json(const contract::Scene& scene) {
  json shapes = json::array();
  for (const contract::SceneShape& shape : scene.shapes) {
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

json buses_json(const std::vector<contract::BusTable>& buses) {
  json out = json::array();
  for (const contract::BusTable& bus : buses) {
    json servos = json::array();
    for (const contract::ServoRow& servo : bus.servos) {
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
    const contract::BusCounters& c = bus.counters;
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

Answer handle(const contract::Facets& host, const std::string& method, const std::string& path, const std::string& body) {
  static const std::vector<std::regex> patterns = [] {
    std::vector<std::regex> compiled;
    for (const Route& route : kRoutes) compiled.emplace_back(route.pattern);
    return compiled;
  }();
  for (std::size_t i = 0; i < patterns.size(); ++i) {
    std::smatch matches;
    if (std::regex_match(path, matches, patterns[i])) return kRoutes[i].serve(host, Call{method, matches, body});
  }
  return refusal(404, "no such path: " + path);
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

HttpApi::HttpApi(const contract::Facets& host, const std::string& address, uint16_t port, const StaticFiles& files,
                 std::string token)
    : host_(host), address_(address), server_(std::make_unique<httplib::Server>()) {
  if (host_.simulation == nullptr) throw std::invalid_argument("the control API needs a host that offers the simulation");
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
  // A camera's latest still as PNG (the only answer that is not JSON, unless it is an error).
  server_->Get(R"(/api/camera/(.+))", [this](const httplib::Request& request, httplib::Response& response) {
    const contract::Result<contract::CameraStill> answer = host_.simulation->camera_still(request.matches[1]);
    if (!answer.ok()) {
      response.status = http_status(answer.error().kind);
      response.set_content(error_body(answer.error().message).dump(), "application/json");
      return;
    }
    const contract::CameraStill& still = answer.value();
    response.status = 200;
    response.set_header("Cache-Control", "no-store");
    response.set_header("X-Sim-Time", std::to_string(still.sim_time_s));
    // A replay serves the still as recorded: PNG, or JPEG (its magic bytes FF D8 FF).
    const bool jpeg = still.png.size() >= 3 && static_cast<uint8_t>(still.png[0]) == 0xFF &&
                      static_cast<uint8_t>(still.png[1]) == 0xD8 && static_cast<uint8_t>(still.png[2]) == 0xFF;
    response.set_content(still.png, jpeg ? "image/jpeg" : "image/png");
  });
  for (const Route& route : kRoutes) {
    auto serve = [this, &route](const httplib::Request& request, httplib::Response& response) {
      const Answer answer = route.serve(host_, Call{request.method, request.matches, request.body});
      response.status = answer.status;
      response.set_content(answer.body.dump(), "application/json");
    };
    server_->Get(route.pattern, serve);
    server_->Post(route.pattern, serve);
    server_->Put(route.pattern, serve);
    server_->Delete(route.pattern, serve);
  }
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
