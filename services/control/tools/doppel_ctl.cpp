// doppel-ctl: the simulation-control API of a running doppel from a shell (docs/control.md).
// Prints the JSON answer; a refused request prints doppel's reason and exits 1, an unreachable
// doppel exits 2.
#include <httplib.h>

#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "base/command_line.h"
#include "bus/link_directory.h"
#include "contract/access_token.h"
#include "control/access.h"
#include "control/http_api.h"

namespace {

using nlohmann::json;

// A robot is named by its index in `doppel-ctl state` or by its name.
json robot_ref(const std::string& text) {
  const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  return digits && text.size() < 10 ? json(std::stoll(text)) : json(text);
}

// A team is A, B or its team number.
json team_ref(const std::string& text) {
  const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  return digits && text.size() < 4 ? json(std::stoi(text)) : json(text);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("doppel-ctl: pause, step, reset, place and push a running doppel's simulation; inject faults; drive its "
               "GameController and team-communication hub",
               "doppel-ctl");
  std::string url = "http://127.0.0.1:" + std::to_string(doppel::control::kDefaultPort);
  app.add_option("--url", url, "doppel's control address (doppel --viewer PORT)")->capture_default_str();
  std::string link_dir = doppel::bus::default_link_dir();
  app.add_option("--link-dir", link_dir,
                 "doppel's link directory (doppel --link-dir), where its access token is (token-PORT); $DOPPEL_TOKEN "
                 "overrides it")
      ->capture_default_str();
  app.require_subcommand(1);

  app.add_subcommand("state", "time, pause state, every robot's pose, joints and whether it fell");
  app.add_subcommand("pause", "freeze the world (the bus answers with frozen values)");
  app.add_subcommand("resume", "let the world run again");
  app.add_subcommand("reset", "world and servos to their power-on state");
  uint32_t step_ms = 0;
  app.add_subcommand("step", "while paused: run MS milliseconds of simulation, then stay paused")
      ->add_option("MS", step_ms)->required()->transform(doppel::number_in<uint32_t>(1, doppel::control::kMaxStepMs));
  std::string robot;
  double x = 0, y = 0, yaw = 0, fx = 0, fy = 0, fz = 0;
  uint32_t push_ms = 0;
  CLI::App* place = app.add_subcommand("place", "stand ROBOT (index or name) in its initial pose at X Y (m), heading YAW (rad)");
  place->add_option("ROBOT", robot)->required();
  place->add_option("X", x)->required()->transform(doppel::number_in<double>(-1e3, 1e3));
  place->add_option("Y", y)->required()->transform(doppel::number_in<double>(-1e3, 1e3));
  place->add_option("YAW", yaw)->required()->transform(doppel::number_in<double>(-1e3, 1e3));
  CLI::App* push = app.add_subcommand("push", "push ROBOT's trunk with FX FY FZ (N, field frame) for MS milliseconds");
  push->add_option("ROBOT", robot)->required();
  push->add_option("FX", fx)->required()->transform(doppel::number_in<double>(-1e4, 1e4));
  push->add_option("FY", fy)->required()->transform(doppel::number_in<double>(-1e4, 1e4));
  push->add_option("FZ", fz)->required()->transform(doppel::number_in<double>(-1e4, 1e4));
  push->add_option("MS", push_ms)->required()->transform(doppel::number_in<uint32_t>(1, doppel::control::kMaxPushMs));
  CLI::App* ball = app.add_subcommand("ball", "put the ball at rest at X Y (m)");
  ball->add_option("X", x)->required()->transform(doppel::number_in<double>(-1e3, 1e3));
  ball->add_option("Y", y)->required()->transform(doppel::number_in<double>(-1e3, 1e3));
  uint32_t wm_robot = 0;
  std::optional<bool> wm_enabled, wm_nearest;
  std::optional<double> wm_rate, wm_fov, wm_range, wm_position_sigma, wm_angle_sigma, wm_dropout, wm_latency;
  std::optional<uint64_t> wm_seed;
  CLI::App* world_model = app.add_subcommand(
      "world-model", "show ROBOT's world-model sensor settings (doppel --world-model), or change those given");
  world_model->add_option("ROBOT", wm_robot, "the robot's index")->required()->transform(doppel::number_in<uint32_t>(0, 999));
  world_model->add_option("--enabled", wm_enabled, "publish (true) or not (false)");
  world_model->add_option("--rate", wm_rate, "messages per second of simulation time, (0, 1000]");
  world_model->add_option("--fov", wm_fov, "field of view in degrees about the camera's axis: 0 = all around, else (0, 180)");
  world_model->add_option("--max-range", wm_range, "metres; 0 = no limit");
  world_model->add_option("--nearest-ball", wm_nearest, "report only the nearest ball seen (true/false)");
  world_model->add_option("--position-sigma", wm_position_sigma, "Gaussian noise on positions, m");
  world_model->add_option("--angle-sigma", wm_angle_sigma, "Gaussian noise on headings, rad");
  world_model->add_option("--dropout", wm_dropout, "probability that a seen object is missing, [0, 1)");
  world_model->add_option("--latency", wm_latency, "the message describes the world this long ago, [0, 1] s");
  world_model->add_option("--seed", wm_seed, "the noise sequence");

  // doppel-ctl game ...: the GameController (docs/gamecontroller.md).
  CLI::App* game = app.add_subcommand("game", "the GameController: status (default), on, off, state, goal, penalize, ...");
  std::string team, state, kind, penalty_reason;
  uint32_t player = 0, seconds = 30, score = 0, mode = 0;
  game->require_subcommand(0, 1);
  game->add_subcommand("status", "the game, its penalties and the robots' return packets");
  game->add_subcommand("on", "start doppel's GameController, or let it send again after stepping aside");
  game->add_subcommand("off", "stop sending (step aside for a real GameController)");
  game->add_subcommand("state", "change the game state")
      ->add_option("STATE", state)->required()->check(CLI::IsMember({"initial", "ready", "set", "playing", "finished"}));
  for (const char* name : {"initial", "ready", "set", "playing", "finished"}) game->add_subcommand(name, std::string("state ") + name);
  game->add_subcommand("goal", "a goal for TEAM (A, B or its number) while PLAYING")->add_option("TEAM", team)->required();
  CLI::App* set_score = game->add_subcommand("score", "set TEAM's score to N (a correction)");
  set_score->add_option("TEAM", team)->required();
  set_score->add_option("N", score)->required()->transform(doppel::number_in<uint32_t>(0, 255));
  game->add_subcommand("kickoff", "TEAM kicks off next (A, B, a team number or drop_ball)")->add_option("TEAM", team)->required();
  CLI::App* penalize = game->add_subcommand("penalize", "penalize PLAYER of TEAM for SECONDS (default 30)");
  penalize->add_option("TEAM", team)->required();
  penalize->add_option("PLAYER", player)->required()->transform(doppel::number_in<uint32_t>(1, doppel::control::kMaxGamePlayers));
  penalize->add_option("SECONDS", seconds)->transform(doppel::number_in<uint32_t>(0, 255));
  penalize->add_option("--reason", penalty_reason, "pickup_or_incapable (default), ball_manipulation, physical_contact, ...");
  CLI::App* unpenalize = game->add_subcommand("unpenalize", "PLAYER of TEAM plays again");
  unpenalize->add_option("TEAM", team)->required();
  unpenalize->add_option("PLAYER", player)->required()->transform(doppel::number_in<uint32_t>(1, doppel::control::kMaxGamePlayers));
  CLI::App* set_play = game->add_subcommand("set-play", "a set play for TEAM while PLAYING (secondary state)");
  set_play->add_option("KIND", kind)->required()->check(CLI::IsMember(
      {"direct_free_kick", "indirect_free_kick", "penalty_kick", "corner_kick", "goal_kick", "throw_in"}));
  set_play->add_option("TEAM", team)->required();
  set_play->add_option("MODE", mode, "secondaryStateInfo[1] (default 0)")->transform(doppel::number_in<uint32_t>(0, 255));
  game->add_subcommand("timeout", "a timeout for TEAM (INITIAL, READY or SET)")->add_option("TEAM", team)->required();
  game->add_subcommand("normal", "end the set play or timeout");

  // doppel-ctl teamcomm ...: the team-communication hub (docs/teamcomm.md).
  CLI::App* teamcomm = app.add_subcommand("teamcomm", "the team-communication hub: status (default), add, remove");
  uint32_t port = 0;
  teamcomm->require_subcommand(0, 1);
  teamcomm->add_subcommand("status", "registered robots and each link's counters");
  CLI::App* add = teamcomm->add_subcommand("add", "register a robot's software: TEAM PLAYER PORT (it receives and sends on PORT)");
  add->add_option("TEAM", score)->required()->transform(doppel::number_in<uint32_t>(0, 255));
  add->add_option("PLAYER", player)->required()->transform(doppel::number_in<uint32_t>(0, 255));
  add->add_option("PORT", port)->required()->transform(doppel::number_in<uint32_t>(1, 65535));
  CLI::App* remove = teamcomm->add_subcommand("remove", "unregister robot TEAM PLAYER");
  remove->add_option("TEAM", score)->required()->transform(doppel::number_in<uint32_t>(0, 255));
  remove->add_option("PLAYER", player)->required()->transform(doppel::number_in<uint32_t>(0, 255));

  // doppel-ctl fault ...: faults on demand (docs/faults.md).
  CLI::App* fault = app.add_subcommand("fault", "faults on demand: list (default), add, clear");
  fault->require_subcommand(0, 1);
  fault->add_subcommand("list", "every fault of the run: number, kind, target, start, end, active");
  std::string fault_kind, fault_robot, fault_clear;
  std::optional<int32_t> fault_bus, fault_id;
  std::optional<double> fault_at, fault_for, fault_rate, fault_value;
  std::optional<uint64_t> fault_seed;
  CLI::App* fault_add = fault->add_subcommand(
      "add", "add a fault: KIND ROBOT [--bus B --id ID] [--value X] [--rate P] [--at S] [--for S] [--seed N]");
  std::string kinds_help;
  for (const doppel::faults::FaultKindInfo& k : doppel::faults::fault_kinds()) {
    kinds_help += "\n  " + std::string(k.name) + (k.value_field.empty() ? "" : " --value " + std::string(k.value_field)) +
                  (k.needs_rate ? " --rate P" : "") + ": " + std::string(k.what);
  }
  fault_add->add_option("KIND", fault_kind, "one of:" + kinds_help)->required();
  fault_add->add_option("ROBOT", fault_robot, "the robot's index or name")->required();
  fault_add->add_option("--bus", fault_bus, "the bus' index in the robot file")->transform(doppel::number_in<int32_t>(0, 255));
  fault_add->add_option("--id", fault_id, "the device's ID in the robot file (collision: the stray device's)")
      ->transform(doppel::number_in<int32_t>(0, 253));
  fault_add->add_option("--value", fault_value, "the kind's value (rise_c_per_s, volts, sigma_rad, scale, delay_us, bias)");
  fault_add->add_option("--rate", fault_rate, "probability per status (collision: per instruction), (0, 1]");
  fault_add->add_option("--at", fault_at, "start at this simulation time, s (default: now)");
  fault_add->add_option("--for", fault_for, "last this long, s (default: until cleared)");
  fault_add->add_option("--seed", fault_seed, "the random stream of rate and noise faults (default 1)");
  fault->add_subcommand("clear", "end fault N now, or every fault (all)")->add_option("N", fault_clear, "a fault's number or all")->required();
  CLI11_PARSE(app, argc, argv);

  const std::string command = app.get_subcommands().front()->get_name();
  json body = json::object();
  std::string path = "/api/" + command;
  std::string method = command == "state" ? "GET" : "POST";
  if (command == "game") {
    path = "/api/game";
    const std::string sub = game->get_subcommands().empty() ? "status" : game->get_subcommands().front()->get_name();
    method = sub == "status" ? "GET" : "POST";
    if (sub == "on" || sub == "off" || sub == "normal") body = {{"command", sub}};
    if (sub == "state") body = {{"command", "state"}, {"state", state}};
    for (const char* name : {"initial", "ready", "set", "playing", "finished"}) {
      if (sub == name) body = {{"command", "state"}, {"state", sub}};
    }
    if (sub == "goal" || sub == "kickoff" || sub == "timeout") body = {{"command", sub}, {"team", team_ref(team)}};
    if (sub == "score") body = {{"command", "score"}, {"team", team_ref(team)}, {"score", score}};
    if (sub == "penalize") {
      body = {{"command", "penalize"}, {"team", team_ref(team)}, {"player", player}, {"seconds", seconds}};
      if (!penalty_reason.empty()) body["reason"] = penalty_reason;
    }
    if (sub == "unpenalize") body = {{"command", "unpenalize"}, {"team", team_ref(team)}, {"player", player}};
    if (sub == "set-play") body = {{"command", "set_play"}, {"kind", kind}, {"team", team_ref(team)}, {"mode", mode}};
  }
  if (command == "teamcomm") {
    const std::string sub = teamcomm->get_subcommands().empty() ? "status" : teamcomm->get_subcommands().front()->get_name();
    path = "/api/teamcomm";
    method = "GET";
    if (sub == "add") {
      path = "/api/teamcomm/robots";
      method = "POST";
      body = {{"team", score}, {"player", player}, {"port", port}};
    }
    if (sub == "remove") {
      path = "/api/teamcomm/robots/" + std::to_string(score) + "/" + std::to_string(player);
      method = "DELETE";
    }
  }
  if (command == "fault") {
    const std::string sub = fault->get_subcommands().empty() ? "list" : fault->get_subcommands().front()->get_name();
    path = "/api/faults";
    method = "GET";
    if (sub == "add") {
      method = "POST";
      body = {{"kind", fault_kind}, {"robot", robot_ref(fault_robot)}};
      if (fault_bus) body["bus"] = *fault_bus;
      if (fault_id) body["id"] = *fault_id;
      if (fault_at) body["start_s"] = *fault_at;
      if (fault_for) body["duration_s"] = *fault_for;
      if (fault_seed) body["seed"] = *fault_seed;
      if (fault_rate) body["rate"] = *fault_rate;
      if (fault_value) {
        const std::optional<doppel::faults::FaultKind> known = doppel::faults::fault_kind(fault_kind);
        const std::string field = known ? std::string(doppel::faults::info(*known).value_field) : "";
        body[field.empty() ? "value" : field] = *fault_value;  // a kind without a value: doppel names the field
      }
    }
    if (sub == "clear") {
      method = "DELETE";
      if (fault_clear != "all") {
        if (fault_clear.empty() || fault_clear.size() > 9 || fault_clear.find_first_not_of("0123456789") != std::string::npos) {
          std::fprintf(stderr, "doppel-ctl: fault clear: N must be a fault's number or all, got '%s'\n", fault_clear.c_str());
          return 1;
        }
        path = "/api/faults/" + fault_clear;
      }
    }
  }
  if (command == "step") body = {{"ms", step_ms}};
  if (command == "place") body = {{"robot", robot_ref(robot)}, {"x", x}, {"y", y}, {"yaw", yaw}};
  if (command == "push") body = {{"robot", robot_ref(robot)}, {"fx", fx}, {"fy", fy}, {"fz", fz}, {"ms", push_ms}};
  if (command == "ball") body = {{"x", x}, {"y", y}};
  bool change = false;
  if (command == "world-model") {
    auto put = [&](const char* field, const auto& value) {
      if (value) {
        body[field] = *value;
        change = true;
      }
    };
    put("enabled", wm_enabled);
    put("rate_hz", wm_rate);
    put("fov_deg", wm_fov);
    put("max_range_m", wm_range);
    put("nearest_ball_only", wm_nearest);
    put("position_sigma_m", wm_position_sigma);
    put("angle_sigma_rad", wm_angle_sigma);
    put("dropout", wm_dropout);
    put("latency_s", wm_latency);
    put("seed", wm_seed);
    path = "/api/robots/" + std::to_string(wm_robot) + "/world_model";
    method = change ? "PUT" : "GET";
  }

  httplib::Client client(url);
  if (!client.is_valid()) {
    std::fprintf(stderr, "doppel-ctl: '%s' is not a URL doppel-ctl can use (http://HOST:PORT)\n", url.c_str());
    return 2;
  }
  client.set_connection_timeout(2);
  // The run's access token (control/access.h): $DOPPEL_TOKEN or LINK_DIR/token-PORT. Without one the
  // request goes anyway: a doppel with --no-token needs none, any other answers 401 and says why.
  const std::size_t colon = url.rfind(':');
  const std::string port_text = colon == std::string::npos ? "" : url.substr(colon + 1, url.find('/', colon) - colon - 1);
  const bool numeric = !port_text.empty() && port_text.size() <= 5 && port_text.find_first_not_of("0123456789") == std::string::npos;
  const auto port_number = static_cast<uint16_t>(numeric && std::stoul(port_text) <= 65535 ? std::stoul(port_text) : 80);
  if (const std::optional<std::string> token = doppel::contract::find_access_token(link_dir, port_number)) {
    client.set_bearer_token_auth(token->c_str());
  }
  client.set_read_timeout(static_cast<time_t>(doppel::control::kMaxStepMs / 1000 + 30));
  httplib::Result result = method == "GET"      ? client.Get(path)
                           : method == "DELETE" ? client.Delete(path, "", "application/json")
                           : method == "PUT"    ? client.Put(path, body.dump(), "application/json")
                                                : client.Post(path, body.dump(), "application/json");
  if (!result) {
    std::fprintf(stderr, "doppel-ctl: cannot reach doppel at %s (%s); is it running, with its viewer on (--viewer)?\n",
                 url.c_str(), httplib::to_string(result.error()).c_str());
    return 2;
  }
  const json answer = json::parse(result->body, nullptr, false);
  if (result->status != 200) {
    const std::string reason = !answer.is_discarded() && answer.contains("error") ? answer["error"].get<std::string>() : result->body;
    std::fprintf(stderr, "doppel-ctl: %s: %s (HTTP %d)\n", command.c_str(), reason.c_str(), result->status);
    if (result->status == 401) {
      std::fprintf(stderr, "doppel-ctl: the token was looked for in %s (--link-dir names doppel's link directory)\n",
                   doppel::contract::token_file_path(link_dir, port_number).c_str());
    }
    return 1;
  }
  std::cout << (answer.is_discarded() ? result->body : answer.dump(2)) << "\n";
  return 0;
}
