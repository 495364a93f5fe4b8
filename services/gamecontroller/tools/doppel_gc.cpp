// doppel-gc: a small RoboCup GameController (Humanoid League protocol, struct version 12) for a
// robot's software under test. Sends the game state twice a second to --address:--port (127.0.0.1
// unless named) and reads commands, one per line, on stdin. See docs/gamecontroller.md.

#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

#include "base/command_line.h"
#include "gamecontroller/game_controller.h"

namespace gc = doppel::gamecontroller;

namespace {

constexpr const char* kHelp =
    "commands: ready | set | play | finish | goal A|B | penalise A|B PLAYER SECONDS | unpenalise A|B PLAYER |\n"
    "          state | returns | help | quit\n";

int team_index(const std::string& name) {
  if (name == "A" || name == "a") {
    return 0;
  }
  if (name == "B" || name == "b") {
    return 1;
  }
  return -1;
}

void print_state(const gc::GameControlData& data) {
  std::cout << gc::to_string(data.state) << (data.first_half ? " first half" : " second half")
            << ", kick-off " << static_cast<int>(data.kick_off_team) << ", " << data.secs_remaining
            << " s left, packet " << static_cast<int>(data.packet_number) << "\n";
  for (std::size_t t = 0; t < 2; ++t) {
    const gc::TeamInfo& team = data.teams[t];
    std::cout << (t == 0 ? "A" : "B") << " team " << static_cast<int>(team.team_number) << ": score "
              << static_cast<int>(team.score);
    for (std::size_t p = 0; p < gc::kMaxPlayers; ++p) {
      if (team.players[p].penalty != gc::kPenaltyNone) {
        std::cout << ", player " << p + 1 << " penalised (" << static_cast<int>(team.players[p].secs_till_unpenalised)
                  << " s)";
      }
    }
    std::cout << "\n";
  }
}

// One command line; returns the refusal or error message, empty when done.
std::string run(gc::GameController& controller, const std::string& line, bool& quit) {
  std::istringstream words(line);
  std::string command;
  words >> command;
  if (command.empty()) {
    return {};
  }
  if (command == "quit" || command == "exit") {
    quit = true;
    return {};
  }
  if (command == "help") {
    std::cout << kHelp;
    return {};
  }
  if (command == "state") {
    print_state(controller.snapshot());
    return {};
  }
  if (command == "returns") {
    const gc::GameControlData data = controller.snapshot();
    for (const gc::TeamInfo& team : data.teams) {
      for (std::uint8_t player = 1; player <= gc::kMaxPlayers; ++player) {
        if (const auto record = controller.last_return(team.team_number, player)) {
          std::cout << "team " << static_cast<int>(team.team_number) << " player " << static_cast<int>(player)
                    << ": message " << static_cast<int>(record->message) << ", " << record->count << " packets\n";
        }
      }
    }
    const gc::GameControllerCounters c = controller.counters();
    std::cout << "sent " << c.sent << ", returns " << c.returns << ", ignored: " << c.wrong_size << " wrong size, "
              << c.wrong_header << " wrong header, " << c.wrong_version << " wrong version, " << c.unknown_robot
              << " unknown robot\n";
    return {};
  }
  if (command == "ready") return controller.with_game([](gc::Game& g) { return g.ready(); });
  if (command == "set") return controller.with_game([](gc::Game& g) { return g.set(); });
  if (command == "play") return controller.with_game([](gc::Game& g) { return g.play(); });
  if (command == "finish") return controller.with_game([](gc::Game& g) { return g.finish(); });
  std::string team;
  words >> team;
  if (command == "goal") {
    return controller.with_game([&](gc::Game& g) { return g.goal(team_index(team)); });
  }
  int player = 0;
  if (command == "penalise") {
    int seconds = 0;
    if (!(words >> player >> seconds)) {
      return "usage: penalise A|B PLAYER SECONDS";
    }
    return controller.with_game([&](gc::Game& g) { return g.penalise(team_index(team), player, seconds); });
  }
  if (command == "unpenalise") {
    if (!(words >> player)) {
      return "usage: unpenalise A|B PLAYER";
    }
    return controller.with_game([&](gc::Game& g) { return g.unpenalise(team_index(team), player); });
  }
  return "unknown command '" + command + "' (help lists them)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"doppel-gc: a RoboCup GameController (Humanoid League protocol, struct version 12); commands on stdin"};
  gc::GameControllerOptions options;
  int team_a = 0;
  int team_b = 0;
  int players = options.players_per_team;
  app.add_option("--team-a", team_a, "team number of team A (cyan, kicks off first)")
      ->required()
      ->transform(doppel::number_in(0, 255));
  app.add_option("--team-b", team_b, "team number of team B (magenta)")
      ->required()
      ->transform(doppel::number_in(0, 255));
  app.add_option("--address", options.address, "where game packets go (IPv4; default loopback only)")
      ->capture_default_str();
  app.add_option("--port", options.port, "game packet port")->capture_default_str()->transform(doppel::number_in(1, 65535));
  app.add_option("--return-address", options.return_address, "address to receive return packets on")
      ->capture_default_str();
  app.add_option("--return-port", options.return_port, "return packet port")
      ->capture_default_str()
      ->transform(doppel::number_in(1, 65535));
  app.add_option("--players", players, "players per team")->capture_default_str()->transform(doppel::number_in(1, 11));
  CLI11_PARSE(app, argc, argv);
  if (team_a == team_b) {
    std::cerr << "doppel-gc: --team-a and --team-b must differ (both are " << team_a << ")\n";
    return 2;
  }
  options.team_a = static_cast<std::uint8_t>(team_a);
  options.team_b = static_cast<std::uint8_t>(team_b);
  options.players_per_team = static_cast<std::uint8_t>(players);

  std::string error;
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options, error);
  if (!controller) {
    std::cerr << "doppel-gc: " << error << "\n";
    return 1;
  }
  controller->start();
  std::cout << "doppel-gc: sending to " << gc::to_string(controller->destination()) << " at 2 Hz, return packets on "
            << options.return_address << ":" << controller->return_port() << "\n"
            << kHelp << std::flush;
  std::string line;
  bool quit = false;
  while (!quit && std::getline(std::cin, line)) {
    const std::string message = run(*controller, line, quit);
    std::cout << (message.empty() ? "ok" : "refused: " + message) << "\n" << std::flush;
  }
  controller->stop();
  return 0;
}
