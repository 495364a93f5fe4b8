#include "gamecontroller/game_controller.h"

#include <algorithm>

namespace doppel::gamecontroller {

namespace {
constexpr std::uint32_t kLoopback = 0x7f000001;

std::string refused(std::string_view command, State state) {
  return std::string(command) + " is not allowed in " + std::string(to_string(state));
}
}  // namespace

Game::Game(const GameControllerOptions& options) : half_seconds_(options.half_seconds) {
  data_.players_per_team = options.players_per_team;
  data_.secs_remaining = options.half_seconds;
  data_.teams[0].team_number = options.team_a;
  data_.teams[0].team_colour = kTeamCyan;
  data_.teams[1].team_number = options.team_b;
  data_.teams[1].team_colour = kTeamMagenta;
  data_.kick_off_team = options.team_a;
}

std::string Game::ready() {
  const bool second_half = data_.state == State::kFinished && data_.first_half == 1;
  if (data_.state != State::kInitial && data_.state != State::kPlaying && !second_half) {
    return refused("ready", data_.state);
  }
  if (second_half) {
    // The team that did not kick off the first half kicks off the second.
    data_.first_half = 0;
    data_.kick_off_team = data_.teams[1].team_number;
    data_.secs_remaining = half_seconds_;
    half_clock_ = std::chrono::milliseconds(0);
  }
  data_.state = State::kReady;
  return {};
}

std::string Game::set() {
  if (data_.state != State::kReady) {
    return refused("set", data_.state);
  }
  data_.state = State::kSet;
  return {};
}

std::string Game::play() {
  if (data_.state != State::kSet) {
    return refused("play", data_.state);
  }
  data_.state = State::kPlaying;
  return {};
}

std::string Game::finish() {
  if (data_.state != State::kReady && data_.state != State::kSet && data_.state != State::kPlaying) {
    return refused("finish", data_.state);
  }
  data_.state = State::kFinished;
  return {};
}

std::string Game::goal(int team) {
  if (team != 0 && team != 1) {
    return "goal needs team A or B";
  }
  if (data_.state != State::kPlaying) {
    return refused("goal", data_.state);
  }
  TeamInfo& scorer = data_.teams[static_cast<std::size_t>(team)];
  if (scorer.score == 255) {
    return "the score of team " + std::to_string(scorer.team_number) + " is at its maximum (255)";
  }
  ++scorer.score;
  data_.kick_off_team = data_.teams[static_cast<std::size_t>(1 - team)].team_number;
  data_.state = State::kReady;
  return {};
}

std::string Game::penalise(int team, int player, int seconds, std::uint8_t penalty) {
  if (team != 0 && team != 1) {
    return "penalise needs team A or B";
  }
  if (player < 1 || player > static_cast<int>(kMaxPlayers)) {
    return "player " + std::to_string(player) + " is not in 1.." + std::to_string(kMaxPlayers);
  }
  if (seconds < 0 || seconds > 255) {
    return "penalty time " + std::to_string(seconds) + " s is not in 0..255";
  }
  if (penalty == kPenaltyNone) {
    return "penalise needs a penalty code other than 0 (none)";
  }
  const auto t = static_cast<std::size_t>(team);
  const auto p = static_cast<std::size_t>(player - 1);
  data_.teams[t].players[p].penalty = penalty;
  data_.teams[t].players[p].secs_till_unpenalised = static_cast<std::uint8_t>(seconds);
  penalty_clock_[t][p] = std::chrono::seconds(seconds);
  return {};
}

std::string Game::unpenalise(int team, int player) {
  if (team != 0 && team != 1) {
    return "unpenalise needs team A or B";
  }
  if (player < 1 || player > static_cast<int>(kMaxPlayers)) {
    return "player " + std::to_string(player) + " is not in 1.." + std::to_string(kMaxPlayers);
  }
  const auto t = static_cast<std::size_t>(team);
  const auto p = static_cast<std::size_t>(player - 1);
  if (data_.teams[t].players[p].penalty == kPenaltyNone) {
    return "player " + std::to_string(player) + " of team " + std::to_string(data_.teams[t].team_number) +
           " is not penalised";
  }
  data_.teams[t].players[p].penalty = kPenaltyNone;
  data_.teams[t].players[p].secs_till_unpenalised = 0;
  penalty_clock_[t][p] = std::chrono::milliseconds(0);
  return {};
}

std::string Game::secondary(SecondaryState kind, int team, std::uint8_t mode) {
  if (kind == SecondaryState::kNormal) {
    data_.secondary_state = SecondaryState::kNormal;
    data_.secondary_state_info = {};
    return {};
  }
  if (team != 0 && team != 1) {
    return "a set play or timeout needs team A or B";
  }
  switch (kind) {
    case SecondaryState::kDirectFreekick:
    case SecondaryState::kIndirectFreekick:
    case SecondaryState::kPenaltyKick:
    case SecondaryState::kCornerKick:
    case SecondaryState::kGoalKick:
    case SecondaryState::kThrowIn:
      if (data_.state != State::kPlaying) {
        return refused("a set play", data_.state);
      }
      break;
    case SecondaryState::kTimeout:
      if (data_.state != State::kInitial && data_.state != State::kReady && data_.state != State::kSet) {
        return refused("a timeout", data_.state);
      }
      break;
    default:
      return "penalty shoot-out and overtime are not commands";
  }
  data_.secondary_state = kind;
  data_.secondary_state_info = {data_.teams[static_cast<std::size_t>(team)].team_number, mode, 0, 0};
  return {};
}

void Game::advance(std::chrono::milliseconds elapsed) {
  using std::chrono::milliseconds;
  if (data_.state == State::kPlaying) {
    half_clock_ += elapsed;
    const auto whole = std::chrono::duration_cast<std::chrono::seconds>(half_clock_);
    half_clock_ -= whole;
    data_.secs_remaining = static_cast<std::uint16_t>(
        std::max<std::int64_t>(0, static_cast<std::int64_t>(data_.secs_remaining) - whole.count()));
  }
  if (data_.state == State::kReady || data_.state == State::kSet || data_.state == State::kPlaying) {
    for (std::size_t t = 0; t < 2; ++t) {
      for (std::size_t p = 0; p < kMaxPlayers; ++p) {
        RobotInfo& robot = data_.teams[t].players[p];
        if (robot.penalty == kPenaltyNone) {
          continue;
        }
        penalty_clock_[t][p] = std::max(milliseconds(0), penalty_clock_[t][p] - elapsed);
        // Rounded up, as a countdown shows it: 0.2 s left still reads 1.
        robot.secs_till_unpenalised = static_cast<std::uint8_t>((penalty_clock_[t][p].count() + 999) / 1000);
      }
    }
  }
}

std::unique_ptr<GameController> GameController::create(const GameControllerOptions& options, std::string& error) {
  const std::optional<std::uint32_t> destination = parse_ipv4(options.address);
  if (!destination) {
    error = "'" + options.address + "' is not an IPv4 address (a.b.c.d)";
    return nullptr;
  }
  const std::optional<std::uint32_t> return_address = parse_ipv4(options.return_address);
  if (!return_address) {
    error = "'" + options.return_address + "' is not an IPv4 address (a.b.c.d)";
    return nullptr;
  }
  // Broadcast only when the user named a broadcast-looking address (x.x.x.255).
  const bool broadcast = (*destination & 0xff) == 0xff;
  const bool loopback = (*destination >> 24) == 127;
  std::optional<UdpSocket> sender = UdpSocket::open(loopback ? kLoopback : 0, 0, broadcast, error);
  if (!sender) {
    return nullptr;
  }
  std::optional<UdpSocket> returns = UdpSocket::open(*return_address, options.return_port, false, error);
  if (!returns) {
    return nullptr;
  }
  std::unique_ptr<GameController> controller(new GameController(options, std::move(*sender), std::move(*returns),
                                                                Endpoint{*destination, options.port}));
  if (!options.watch_address.empty()) {
    const std::optional<std::uint32_t> watch = parse_ipv4(options.watch_address);
    if (!watch) {
      error = "'" + options.watch_address + "' is not an IPv4 address (a.b.c.d)";
      return nullptr;
    }
    std::string watch_error;
    controller->watch_ = UdpSocket::open(*watch, options.watch_port, false, watch_error, true);
    if (!controller->watch_) {
      controller->watch_error_ = watch_error;
    }
  }
  return controller;
}

GameController::GameController(const GameControllerOptions& options, UdpSocket sender, UdpSocket returns,
                               Endpoint destination)
    : options_(options),
      sender_(std::move(sender)),
      returns_(std::move(returns)),
      destination_(destination),
      game_(options),
      sending_(options.sending) {}

GameController::~GameController() { stop(); }

void GameController::start() {
  {
    std::lock_guard lock(mutex_);
    if (running_) {
      return;
    }
    running_ = true;
  }
  sender_thread_ = std::thread([this] { send_loop(); });
  receiver_thread_ = std::thread([this] { receive_loop(); });
  if (watch_) {
    watch_thread_ = std::thread([this] { watch_loop(); });
  }
}

void GameController::stop() {
  {
    std::lock_guard lock(mutex_);
    running_ = false;
  }
  wake_.notify_all();
  if (sender_thread_.joinable()) {
    sender_thread_.join();
  }
  if (receiver_thread_.joinable()) {
    receiver_thread_.join();
  }
  if (watch_thread_.joinable()) {
    watch_thread_.join();
  }
}

GameControlData GameController::snapshot() const {
  std::lock_guard lock(mutex_);
  return game_.data();
}

bool GameController::send_now() {
  std::lock_guard lock(mutex_);
  return send_locked();
}

bool GameController::send_locked() {
  DataBytes bytes{};
  GameControlData& data = game_.data();
  data.packet_number = packet_number_++;
  encode(data, bytes);
  std::string error;
  const bool sent = sender_.send_to(destination_, bytes, error);
  ++(sent ? counters_.sent : counters_.send_errors);
  return sent;
}

void GameController::send_loop() {
  auto last = std::chrono::steady_clock::now();
  auto next = last;
  std::unique_lock lock(mutex_);
  while (running_) {
    const auto now = std::chrono::steady_clock::now();
    game_.advance(std::chrono::duration_cast<std::chrono::milliseconds>(now - last));
    last = now;
    if (sending_) {
      send_locked();
    }
    next += options_.period;
    wake_.wait_until(lock, next, [this] { return !running_; });
  }
}

void GameController::receive_loop() {
  std::array<std::uint8_t, 64> buffer{};
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (!running_) {
        return;
      }
    }
    const std::optional<std::size_t> length = returns_.receive(buffer, std::chrono::milliseconds(100));
    if (!length) {
      continue;
    }
    ReturnData data;
    const DecodeStatus status =
        decode(std::span<const std::uint8_t>(buffer.data(), std::min(*length, buffer.size())), data);
    std::lock_guard lock(mutex_);
    switch (status) {
      case DecodeStatus::kOk: {
        const GameControlData& game = game_.data();
        const bool known_team = data.team == game.teams[0].team_number || data.team == game.teams[1].team_number;
        if (!known_team || data.player < 1 || data.player > kMaxPlayers) {
          ++counters_.unknown_robot;
          break;
        }
        ReturnRecord& record = last_returns_[{data.team, data.player}];
        record.message = data.message;
        ++record.count;
        record.last = std::chrono::steady_clock::now();
        ++counters_.returns;
        break;
      }
      case DecodeStatus::kWrongHeader: ++counters_.wrong_header; break;
      case DecodeStatus::kWrongVersion: ++counters_.wrong_version; break;
      case DecodeStatus::kWrongSize:
      case DecodeStatus::kBadValue: ++counters_.wrong_size; break;
    }
  }
}

std::optional<ReturnRecord> GameController::last_return(std::uint8_t team, std::uint8_t player) const {
  std::lock_guard lock(mutex_);
  const auto found = last_returns_.find({team, player});
  if (found == last_returns_.end()) {
    return std::nullopt;
  }
  return found->second;
}

void GameController::watch_loop() {
  std::array<std::uint8_t, kDataSize + 1> buffer{};
  const std::uint16_t own_port = sender_.local_port();
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (!running_) {
        return;
      }
    }
    Endpoint from;
    const std::optional<std::size_t> length = watch_->receive(buffer, std::chrono::milliseconds(100), &from);
    if (!length || *length != kDataSize) {
      continue;
    }
    GameControlData data;
    if (decode(std::span<const std::uint8_t>(buffer.data(), kDataSize), data) != DecodeStatus::kOk) {
      continue;
    }
    // Its own packets, when its destination is a broadcast address the watch receives too: they
    // come from the sender's port (a foreign GameController on this machine has another one).
    if (from.port == own_port) {
      continue;
    }
    std::string reason;
    {
      std::lock_guard lock(mutex_);
      if (!foreign_) {
        foreign_.emplace();
      }
      foreign_->from = from;
      ++foreign_->packets;
      foreign_->last = data;
      foreign_->last_seen = std::chrono::steady_clock::now();
      if (sending_) {
        sending_ = false;
        stepped_aside_ = "another GameController sends from " + to_string(from) + " (teams " +
                         std::to_string(data.teams[0].team_number) + " and " +
                         std::to_string(data.teams[1].team_number) + ", " + std::string(to_string(data.state)) +
                         "): this one stopped sending";
        reason = stepped_aside_;
      }
    }
    if (!reason.empty() && options_.on_step_aside) {
      options_.on_step_aside(reason);
    }
  }
}

std::map<std::pair<std::uint8_t, std::uint8_t>, ReturnRecord> GameController::returns() const {
  std::lock_guard lock(mutex_);
  return last_returns_;
}

void GameController::set_sending(bool on) {
  {
    std::lock_guard lock(mutex_);
    sending_ = on;
    if (on) {
      stepped_aside_.clear();
    }
  }
  wake_.notify_all();
}

bool GameController::sending() const {
  std::lock_guard lock(mutex_);
  return sending_;
}

std::string GameController::stepped_aside() const {
  std::lock_guard lock(mutex_);
  return stepped_aside_;
}

std::optional<ForeignGameController> GameController::foreign() const {
  std::lock_guard lock(mutex_);
  return foreign_;
}

GameControllerCounters GameController::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace doppel::gamecontroller
