#pragma once
// What doppel adds around the robots on a real field: its own GameController (gamecontroller/,
// docs/gamecontroller.md) and the team-communication hub (teamcomm/, docs/teamcomm.md), both off
// unless the options or a control request turn them on, and the control API's view of both
// (contract::GameStatus, contract::TeamcommStatus). Not real-time: each has threads of its own and
// none of it runs on the bus or simulation threads.

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "contract/game.h"
#include "contract/teamcomm.h"
#include "gamecontroller/game_controller.h"
#include "gateway/options.h"
#include "teamcomm/hub.h"

namespace doppel::gateway {

class FieldServices {
 public:
  // Checks the options and opens what they ask for (the GameController's sockets with
  // --gamecontroller, the hub's with --teamcomm). Throws std::runtime_error naming the option.
  explicit FieldServices(const Options& options);
  ~FieldServices();
  FieldServices(const FieldServices&) = delete;
  FieldServices& operator=(const FieldServices&) = delete;

  void start();  // the GameController's and the hub's threads
  void stop();   // idempotent
  std::string describe() const;

  contract::GameStatus game_status();
  contract::Outcome game_command(const contract::GameCommand& command);
  std::optional<contract::TeamcommStatus> teamcomm_status();
  contract::Outcome teamcomm_add(const contract::TeamcommRobot& robot);
  contract::Outcome teamcomm_remove(int team, int player);

  // The hub, for whoever registers robots (the session handshake): Hub::add_robot and
  // remove_robot are thread-safe. Null without --teamcomm.
  teamcomm::Hub* hub() noexcept { return hub_.get(); }

 private:
  // Opens the GameController's sockets (mutex_ held); "" or why it could not.
  std::string open_game_controller();

  gamecontroller::GameControllerOptions gc_options_;
  std::string gc_destination_, gc_return_, gc_watch_;  // as the user gave them (ADDRESS:PORT)
  mutable std::mutex mutex_;  // game_ being created
  std::unique_ptr<gamecontroller::GameController> game_;  // null until turned on
  bool started_ = false;

  teamcomm::HubConfig hub_config_;
  std::unique_ptr<teamcomm::Hub> hub_;
  std::atomic<bool> hub_stop_{false};
  std::thread hub_thread_;
};

// "ADDRESS:PORT" (IPv4, port 0..65535) into its parts; throws std::invalid_argument naming `option`.
std::pair<std::string, uint16_t> address_and_port(const std::string& text, const std::string& option);

}  // namespace doppel::gateway
