#pragma once
// A small stand-in for the Humanoid League's GameController: the state of one game (INITIAL ->
// READY -> SET -> PLAYING -> FINISHED, kick-off team, scores, penalties with their countdown),
// sent as RoboCupGameControlData every 500 ms (2 Hz, as the real GameController sends) to one
// configured address, and the robots' return packets received and kept, the last per (team,
// player). Packets go to 127.0.0.1 unless the caller names another address. Not real-time code:
// one mutex guards the game between the command side and the two network threads.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "gamecontroller/packet.h"
#include "gamecontroller/udp_socket.h"

namespace doppel::gamecontroller {

struct GameControllerOptions {
  std::uint8_t team_a = 1;  // team number of teams[0] (cyan)
  std::uint8_t team_b = 2;  // team number of teams[1] (magenta)
  std::uint8_t players_per_team = 4;
  std::uint16_t half_seconds = 600;
  std::string address = "127.0.0.1";  // where the game packets go; the user must name anything else
  std::uint16_t port = kDataPort;
  std::string return_address = "127.0.0.1";  // where return packets are received
  std::uint16_t return_port = kReturnPort;    // 0: the system picks one (tests)
  std::chrono::milliseconds period{500};
  // Where to watch for another GameController's packets ("" = no watch). A packet "RGme" of this
  // protocol arriving there from anyone but this GameController makes it stop sending (it "steps
  // aside"). The socket shares the port (SO_REUSEADDR, not SO_REUSEPORT); bound to a broadcast
  // address it receives only broadcasts, never a unicast datagram meant for the robots' sockets.
  std::string watch_address;
  std::uint16_t watch_port = kDataPort;  // 0: the system picks one (tests)
  bool sending = true;                   // send from start() on; false: only when set_sending(true)
  // Called (on the watch thread, without the lock held) when it steps aside, with the reason.
  std::function<void(const std::string&)> on_step_aside;
};

// The last packet of another GameController the watch saw.
struct ForeignGameController {
  Endpoint from;
  std::uint64_t packets = 0;
  GameControlData last;
  std::chrono::steady_clock::time_point last_seen;
};

struct ReturnRecord {
  std::uint8_t message = 0;
  std::uint64_t count = 0;
  std::chrono::steady_clock::time_point last;
};

struct GameControllerCounters {
  std::uint64_t sent = 0;
  std::uint64_t send_errors = 0;
  std::uint64_t returns = 0;       // accepted return packets
  std::uint64_t wrong_size = 0;    // not 8 bytes
  std::uint64_t wrong_header = 0;  // not "RGrt"
  std::uint64_t wrong_version = 0;
  std::uint64_t unknown_robot = 0;  // a team not in this game or a player outside 1..kMaxPlayers
};

// The game itself, without sockets: every command checks its preconditions and returns an empty
// string or a message saying why it was refused.
class Game {
 public:
  explicit Game(const GameControllerOptions& options);

  std::string ready();   // INITIAL, PLAYING (a stoppage) or FINISHED after the first half -> READY
  std::string set();     // READY -> SET
  std::string play();    // SET -> PLAYING
  std::string finish();  // READY, SET or PLAYING -> FINISHED (the end of a half)
  // A goal for team index 0 (A) or 1 (B) while PLAYING: score + 1, the other team kicks off, READY.
  std::string goal(int team);
  std::string penalise(int team, int player, int seconds, std::uint8_t penalty = kPenaltyPickupOrIncapable);
  std::string unpenalise(int team, int player);
  // A set play or stoppage of the Humanoid protocol's secondary state (free kicks, penalty kick,
  // corner and goal kick, throw-in: in PLAYING; timeout: in INITIAL, READY or SET) for team index
  // 0 or 1: secondaryStateInfo[0] = its team number, [1] = `mode` (the phase within the set play),
  // the rest 0. kNormal ends it (any team). Penalty shoot-out and overtime are not commands.
  std::string secondary(SecondaryState kind, int team, std::uint8_t mode = 0);
  // Advances the clocks: the half's remaining time while PLAYING, the penalty countdowns while
  // READY, SET or PLAYING (a countdown stops at 0; the robot stays penalised until unpenalise()).
  void advance(std::chrono::milliseconds elapsed);

  const GameControlData& data() const { return data_; }
  GameControlData& data() { return data_; }

 private:
  std::uint16_t half_seconds_;
  GameControlData data_;
  std::chrono::milliseconds half_clock_{0};
  std::array<std::array<std::chrono::milliseconds, kMaxPlayers>, 2> penalty_clock_{};
};

class GameController {
 public:
  // Opens the sockets; nullptr and `error` when an address does not parse or a socket cannot be
  // bound. Nothing is sent before start().
  static std::unique_ptr<GameController> create(const GameControllerOptions& options, std::string& error);
  ~GameController();

  void start();  // the sender (every period) and the return receiver threads
  void stop();

  // Runs `change` on the game under the lock and returns what it returns.
  template <typename F>
  auto with_game(F&& change) {
    std::lock_guard lock(mutex_);
    return std::forward<F>(change)(game_);
  }
  GameControlData snapshot() const;
  // Encodes and sends the current state now (the sender thread sends every period the same way).
  bool send_now();

  std::optional<ReturnRecord> last_return(std::uint8_t team, std::uint8_t player) const;
  // Every robot's last return packet, by (team number, player).
  std::map<std::pair<std::uint8_t, std::uint8_t>, ReturnRecord> returns() const;
  // Starts or stops sending (the game, its clocks and the return receiver go on). Turning it on
  // also forgets a step-aside, so the next foreign packet steps aside again.
  void set_sending(bool on);
  bool sending() const;
  // Why it stopped sending on its own ("" when it did not): the foreign GameController it saw.
  std::string stepped_aside() const;
  std::optional<ForeignGameController> foreign() const;
  // The watch's port (0 without a watch) and why there is none although one was asked for.
  std::uint16_t watch_port() const { return watch_ ? watch_->local_port() : 0; }
  const std::string& watch_error() const { return watch_error_; }
  std::uint16_t sender_port() const { return sender_.local_port(); }
  GameControllerCounters counters() const;
  std::uint16_t return_port() const { return returns_.local_port(); }
  Endpoint destination() const { return destination_; }

 private:
  // send_now() with mutex_ held: the sender checks sending_ and sends under the same lock as the
  // step-aside clears it, so that nothing is sent once a GameController stepped aside.
  bool send_locked();
  GameController(const GameControllerOptions& options, UdpSocket sender, UdpSocket returns, Endpoint destination);
  void send_loop();
  void receive_loop();
  void watch_loop();

  GameControllerOptions options_;
  UdpSocket sender_;
  UdpSocket returns_;
  Endpoint destination_;
  mutable std::mutex mutex_;
  Game game_;
  std::uint8_t packet_number_ = 0;
  std::map<std::pair<std::uint8_t, std::uint8_t>, ReturnRecord> last_returns_;
  GameControllerCounters counters_;
  std::optional<UdpSocket> watch_;
  std::string watch_error_;
  bool sending_ = true;
  std::string stepped_aside_;
  std::optional<ForeignGameController> foreign_;
  std::condition_variable wake_;
  bool running_ = false;
  std::thread sender_thread_;
  std::thread receiver_thread_;
  std::thread watch_thread_;
};

}  // namespace doppel::gamecontroller
