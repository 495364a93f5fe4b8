#include "field_services.h"

#include <pthread.h>

#include <chrono>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace doppel::gateway {
namespace {

namespace gc = gamecontroller;

std::string state_name(gc::State state) {
  switch (state) {
    case gc::State::kInitial: return "initial";
    case gc::State::kReady: return "ready";
    case gc::State::kSet: return "set";
    case gc::State::kPlaying: return "playing";
    case gc::State::kFinished: return "finished";
  }
  return "unknown";
}

// The API's names of the protocol's STATE2_* values, in their order.
constexpr std::array<const char*, 10> kSecondaryNames{"normal",           "penalty_shoot",      "overtime",
                                                      "timeout",          "direct_free_kick",   "indirect_free_kick",
                                                      "penalty_kick",     "corner_kick",        "goal_kick",
                                                      "throw_in"};

std::string penalty_name(uint32_t code) {
  for (const contract::GamePenaltyName& penalty : contract::kGamePenalties) {
    if (penalty.code == code) return penalty.name;
  }
  return "code " + std::to_string(code);
}

const char* return_message(uint8_t message) {
  switch (message) {
    case gc::kReturnManPenalise: return "manual_penalise";
    case gc::kReturnManUnpenalise: return "manual_unpenalise";
    case gc::kReturnAlive: return "alive";
    default: return "unknown";
  }
}

std::string endpoint(const std::string& address, uint16_t port) { return address + ":" + std::to_string(port); }

double seconds_since(std::chrono::steady_clock::time_point then) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - then).count();
}

}  // namespace

std::pair<std::string, uint16_t> address_and_port(const std::string& text, const std::string& option) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw std::invalid_argument(option + " '" + text + "': expected ADDRESS:PORT");
  const std::string address = text.substr(0, colon);
  const std::string port = text.substr(colon + 1);
  if (!gc::parse_ipv4(address)) {
    throw std::invalid_argument(option + " '" + text + "': '" + address + "' is not an IPv4 address (a.b.c.d)");
  }
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) > 65535) {
    throw std::invalid_argument(option + " '" + text + "': port '" + port + "' is not 0..65535");
  }
  return {address, static_cast<uint16_t>(std::stoi(port))};
}

FieldServices::FieldServices(const Options& options)
    : gc_destination_(options.gamecontroller.destination), gc_return_(options.gamecontroller.return_to), gc_watch_(options.gamecontroller.watch) {
  gc_options_.team_a = static_cast<uint8_t>(options.gamecontroller.team_a);
  gc_options_.team_b = static_cast<uint8_t>(options.gamecontroller.team_b);
  gc_options_.players_per_team = static_cast<uint8_t>(options.gamecontroller.players);
  std::tie(gc_options_.address, gc_options_.port) = address_and_port(options.gamecontroller.destination, "--gc-destination");
  std::tie(gc_options_.return_address, gc_options_.return_port) = address_and_port(options.gamecontroller.return_to, "--gc-return");
  if (options.gamecontroller.watch != "off") {
    std::tie(gc_options_.watch_address, gc_options_.watch_port) = address_and_port(options.gamecontroller.watch, "--gc-watch");
  }
  gc_options_.on_step_aside = [](const std::string& reason) {
    std::cerr << "doppel: GameController: " << reason << " (doppel-ctl game on sends again)\n" << std::flush;
  };
  if (options.gamecontroller.enabled) {
    std::lock_guard lock(mutex_);
    if (const std::string error = open_game_controller(); !error.empty()) {
      throw std::runtime_error("--gamecontroller: " + error + " (--gc-return picks another address or port)");
    }
  }
  if (!options.teamcomm.hub.empty()) {
    std::string listen = options.teamcomm.hub;
    if (listen.find(':') == std::string::npos) listen = "127.0.0.1:" + listen;
    std::tie(hub_config_.listen_address, hub_config_.listen_port) = address_and_port(listen, "--teamcomm");
    hub_config_.robot_address = options.teamcomm.robot_address;
    hub_config_.link = options.teamcomm.link;
    hub_config_.seed = options.teamcomm.seed;
    try {
      for (const std::string& robot : options.teamcomm.robots) hub_config_.robots.push_back(teamcomm::parse_robot(robot));
      hub_ = std::make_unique<teamcomm::Hub>(hub_config_);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("--teamcomm: ") + e.what());
    }
  }
}

FieldServices::~FieldServices() { stop(); }

std::string FieldServices::open_game_controller() {
  std::string error;
  game_ = gc::GameController::create(gc_options_, error);
  if (game_ == nullptr) return error;
  if (!gc_options_.watch_address.empty() && game_->watch_port() == 0) {
    std::cerr << "doppel: GameController: not watching for another GameController: " << game_->watch_error()
              << " (a robot's software that binds " << gc_watch_
              << " without SO_REUSEADDR; doppel-ctl game off steps aside by hand)\n";
  }
  return "";
}

void FieldServices::start() {
  {
    std::lock_guard lock(mutex_);
    started_ = true;
    if (game_ != nullptr) game_->start();
  }
  if (hub_ != nullptr && !hub_thread_.joinable()) {
    hub_stop_ = false;
    hub_thread_ = std::thread([this] {
      pthread_setname_np(pthread_self(), "doppel-teamcomm");
      hub_->run(hub_stop_);
    });
  }
}

void FieldServices::stop() {
  {
    std::lock_guard lock(mutex_);
    started_ = false;
    if (game_ != nullptr) game_->stop();
  }
  hub_stop_ = true;
  if (hub_thread_.joinable()) hub_thread_.join();
}

std::string FieldServices::describe() const {
  std::ostringstream out;
  std::lock_guard lock(mutex_);
  if (game_ != nullptr) {
    out << "doppel: GameController (teams " << int(gc_options_.team_a) << " and " << int(gc_options_.team_b) << ") sends to "
        << gc_destination_ << ", return packets on " << gc_return_;
    if (game_->watch_port() != 0) out << "; steps aside for another GameController seen on " << gc_watch_;
    out << "\n";
  }
  if (hub_ != nullptr) {
    out << "doppel: team communication hub on " << hub_config_.listen_address << ":" << hub_->port() << ", "
        << hub_->robots().size() << " robots registered\n";
  }
  return out.str();
}

contract::GameStatus FieldServices::game_status() {
  contract::GameStatus status;
  status.destination = gc_destination_;
  status.return_address = gc_return_;
  std::lock_guard lock(mutex_);
  gc::GameControlData data;
  if (game_ == nullptr) {
    data = gc::Game(gc_options_).data();  // the game it would start with
  } else {
    data = game_->snapshot();
    status.on = true;
    status.sending = game_->sending();
    status.stepped_aside = game_->stepped_aside();
    status.return_address = endpoint(gc_options_.return_address, game_->return_port());
    if (game_->watch_port() != 0) status.watch = endpoint(gc_options_.watch_address, game_->watch_port());
    status.watch_error = game_->watch_error();
    const gc::GameControllerCounters counters = game_->counters();
    status.sent = counters.sent;
    status.bad_returns = counters.wrong_size + counters.wrong_header + counters.wrong_version + counters.unknown_robot;
    for (const auto& [robot, record] : game_->returns()) {
      status.returns.push_back({robot.first, robot.second, return_message(record.message), record.count, seconds_since(record.last)});
    }
    if (const std::optional<gc::ForeignGameController> foreign = game_->foreign()) {
      status.foreign = true;
      status.foreign_from = gc::to_string(foreign->from);
      status.foreign_packets = foreign->packets;
      status.foreign_state = state_name(foreign->last.state);
      for (std::size_t t = 0; t < 2; ++t) {
        status.foreign_teams[t] = foreign->last.teams[t].team_number;
        status.foreign_scores[t] = foreign->last.teams[t].score;
      }
      status.foreign_age_s = seconds_since(foreign->last_seen);
    }
  }
  status.state = state_name(data.state);
  status.first_half = data.first_half != 0;
  status.kick_off_team = data.kick_off_team;
  const auto secondary = static_cast<std::size_t>(data.secondary_state);
  status.secondary_state = secondary < kSecondaryNames.size() ? kSecondaryNames[secondary] : "unknown";
  status.secondary_team = data.secondary_state_info[0];
  status.secondary_mode = data.secondary_state_info[1];
  status.secs_remaining = data.secs_remaining;
  status.packet_number = data.packet_number;
  for (std::size_t t = 0; t < 2; ++t) {
    status.teams[t].number = data.teams[t].team_number;
    status.teams[t].score = data.teams[t].score;
    for (std::size_t p = 0; p < gc::kMaxPlayers; ++p) {
      const gc::RobotInfo& robot = data.teams[t].players[p];
      if (robot.penalty == gc::kPenaltyNone) continue;
      status.teams[t].penalties.push_back(
          {static_cast<uint32_t>(p + 1), robot.penalty, penalty_name(robot.penalty), robot.secs_till_unpenalised});
    }
  }
  return status;
}

contract::Outcome FieldServices::game_command(const contract::GameCommand& command) {
  std::lock_guard lock(mutex_);
  const std::string& c = command.command;
  if (c == "off") {
    if (game_ != nullptr) game_->set_sending(false);
    return contract::Outcome::done();
  }
  if (game_ == nullptr) {
    if (c != "on") {
      return contract::Outcome::fail(contract::ErrorKind::kConflict, "the GameController is off: turn it on first (doppel-ctl game on, or doppel --gamecontroller)");
    }
    if (const std::string error = open_game_controller(); !error.empty()) return contract::Outcome::fail(contract::ErrorKind::kConflict, error);
    if (started_) game_->start();
    return contract::Outcome::done();
  }
  if (c == "on") {
    game_->set_sending(true);
    return contract::Outcome::done();
  }
  const gc::GameControllerOptions& options = gc_options_;
  const std::string refused = game_->with_game([&](gc::Game& game) -> std::string {
    if (c == "state") {
      if (command.state == "initial") {
        game = gc::Game(options);  // a new game
        return "";
      }
      if (command.state == "ready") return game.ready();
      if (command.state == "set") return game.set();
      if (command.state == "playing") return game.play();
      return game.finish();
    }
    if (c == "goal") return game.goal(command.team);
    if (c == "score") {
      game.data().teams[static_cast<std::size_t>(command.team)].score = static_cast<uint8_t>(command.score);
      return "";
    }
    if (c == "kickoff") {
      if (game.data().state == gc::State::kPlaying) return "kickoff is not allowed in PLAYING";
      game.data().kick_off_team =
          command.team < 0 ? gc::kDropBall : game.data().teams[static_cast<std::size_t>(command.team)].team_number;
      return "";
    }
    if (c == "penalize") {
      return game.penalise(command.team, static_cast<int>(command.player), static_cast<int>(command.seconds),
                           static_cast<uint8_t>(command.penalty));
    }
    if (c == "unpenalize") return game.unpenalise(command.team, static_cast<int>(command.player));
    if (c == "timeout") return game.secondary(gc::SecondaryState::kTimeout, command.team);
    if (c == "normal") return game.secondary(gc::SecondaryState::kNormal, -1);
    if (c == "set_play") {
      for (std::size_t k = 0; k < kSecondaryNames.size(); ++k) {
        if (command.set_play == kSecondaryNames[k]) {
          return game.secondary(static_cast<gc::SecondaryState>(k), command.team, static_cast<uint8_t>(command.mode));
        }
      }
      return "no set play '" + command.set_play + "'";
    }
    return "no command '" + c + "'";
  });
  if (!refused.empty()) return contract::Outcome::fail(contract::ErrorKind::kConflict, refused);
  // The robots hear the change now, not at the next 500 ms tick (as the real GameController sends
  // at once on a button press).
  if (game_->sending()) game_->send_now();
  return contract::Outcome::done();
}

std::optional<contract::TeamcommStatus> FieldServices::teamcomm_status() {
  if (hub_ == nullptr) return std::nullopt;
  contract::TeamcommStatus status;
  status.listen = endpoint(hub_config_.listen_address, hub_->port());
  status.robot_address = hub_config_.robot_address;
  status.loss = hub_config_.link.loss_probability;
  status.delay_ms = static_cast<double>(hub_config_.link.delay_ns) * 1e-6;
  status.jitter_ms = static_cast<double>(hub_config_.link.jitter_ns) * 1e-6;
  const teamcomm::HubCounters counters = hub_->counters();
  status.received = counters.received;
  status.unknown_sender = counters.unknown_sender;
  status.oversized = counters.oversized;
  for (const teamcomm::Robot& robot : hub_->robots()) status.robots.push_back({robot.team, robot.player, robot.port});
  const auto port_of = [&status](int team, int player) -> uint16_t {
    for (const contract::TeamcommRobot& robot : status.robots) {
      if (robot.team == team && robot.player == player) return robot.port;
    }
    return 0;
  };
  for (const teamcomm::LinkCounters& link : counters.links) {
    status.links.push_back({{link.from_team, link.from_player, port_of(link.from_team, link.from_player)},
                            {link.to_team, link.to_player, port_of(link.to_team, link.to_player)},
                            link.relayed,
                            link.dropped,
                            link.delayed,
                            link.queue_full,
                            link.send_errors});
  }
  return status;
}

contract::Outcome FieldServices::teamcomm_add(const contract::TeamcommRobot& robot) {
  if (hub_ == nullptr) return contract::Outcome::fail(contract::ErrorKind::kNotFound, "no team-communication hub (doppel --teamcomm)");
  try {
    hub_->add_robot({robot.team, robot.player, robot.port});
  } catch (const std::invalid_argument& e) {
    return contract::Outcome::fail(contract::ErrorKind::kConflict, e.what());
  }
  return contract::Outcome::done();
}

contract::Outcome FieldServices::teamcomm_remove(int team, int player) {
  if (hub_ == nullptr) return contract::Outcome::fail(contract::ErrorKind::kNotFound, "no team-communication hub (doppel --teamcomm)");
  if (!hub_->remove_robot(team, player)) {
    return contract::Outcome::fail(contract::ErrorKind::kNotFound, "no robot " + std::to_string(team) + ":" + std::to_string(player) + " is registered");
  }
  return contract::Outcome::done();
}

}  // namespace doppel::gateway
