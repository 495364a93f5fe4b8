// doppel-teamcomm: the team-communication hub as a program (docs/teamcomm.md). Relays each team
// message a registered robot sends to the hub to the other robots of its team, through the loss
// and delay model, until SIGINT/SIGTERM; then prints the counters of every link.
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <string>

#include "teamcomm/hub.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  using namespace doppel::teamcomm;
  CLI::App app{"doppel-teamcomm: relays team messages between robots' software on one machine, "
               "as the field's broadcast would, with optional WiFi loss and delay"};
  std::string listen = "127.0.0.1:3737";
  std::vector<std::string> robots;
  HubConfig config;
  double delay_ms = 0.0, jitter_ms = 0.0;
  std::string jitter_kind = "uniform";
  app.add_option("--listen", listen, "ADDRESS:PORT the hub receives on (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--robot", robots, "TEAM:PLAYER:PORT of a robot's software (receives and sends on PORT)")
      ->required();
  app.add_option("--robot-address", config.robot_address, "IPv4 address the robots' software runs on")
      ->capture_default_str();
  app.add_option("--loss", config.link.loss_probability, "per-relay loss probability")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str();
  app.add_option("--delay-ms", delay_ms, "fixed delay per relay, ms")->check(CLI::Range(0.0, 60000.0));
  app.add_option("--jitter-ms", jitter_ms, "jitter per relay, ms (uniform width or normal sigma)")
      ->check(CLI::Range(0.0, 60000.0));
  app.add_option("--jitter", jitter_kind, "jitter distribution")
      ->check(CLI::IsMember({"uniform", "normal"}))->capture_default_str();
  app.add_option("--burst-enter", config.link.p_good_to_bad,
                 "Gilbert-Elliott: per-relay probability to enter the bad state (turns the burst model on)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--burst-leave", config.link.p_bad_to_good, "Gilbert-Elliott: per-relay probability to leave it")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str();
  app.add_option("--burst-loss", config.link.loss_in_bad, "Gilbert-Elliott: loss probability in the bad state")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str();
  app.add_option("--seed", config.seed, "seed of the loss and delay models")->capture_default_str();
  app.add_option("--max-bytes", config.max_payload_bytes, "longest datagram relayed")
      ->check(CLI::Range(1, 65507))->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) throw std::invalid_argument("--listen '" + listen + "': expected ADDRESS:PORT");
    config.listen_address = listen.substr(0, colon);
    const std::string port = listen.substr(colon + 1);
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(port) > 65535) {
      throw std::invalid_argument("--listen '" + listen + "': port '" + port + "' is not 0..65535");
    }
    config.listen_port = static_cast<std::uint16_t>(std::stoi(port));
    for (const std::string& text : robots) config.robots.push_back(parse_robot(text));
    config.link.delay_ns = static_cast<std::int64_t>(delay_ms * 1e6);
    config.link.jitter_ns = static_cast<std::int64_t>(jitter_ms * 1e6);
    config.link.jitter = jitter_kind == "normal" ? Jitter::kHalfNormal : Jitter::kUniform;
    config.link.burst = app.count("--burst-enter") > 0;

    Hub hub(config);
    struct sigaction action{};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    std::printf("doppel-teamcomm: listening on %s:%u, %zu robots\n", config.listen_address.c_str(),
                static_cast<unsigned>(hub.port()), config.robots.size());
    std::fflush(stdout);
    hub.run(g_stop);

    const HubCounters counters = hub.counters();
    std::printf("received %llu, unknown sender %llu, oversized %llu\n",
                static_cast<unsigned long long>(counters.received),
                static_cast<unsigned long long>(counters.unknown_sender),
                static_cast<unsigned long long>(counters.oversized));
    std::printf("link (team:player -> team:player)  relayed  dropped  delayed  queue_full  send_errors\n");
    for (const LinkCounters& link : counters.links) {
      std::printf("%d:%d -> %d:%d  %llu  %llu  %llu  %llu  %llu\n", link.from_team, link.from_player, link.to_team,
                  link.to_player, static_cast<unsigned long long>(link.relayed),
                  static_cast<unsigned long long>(link.dropped), static_cast<unsigned long long>(link.delayed),
                  static_cast<unsigned long long>(link.queue_full),
                  static_cast<unsigned long long>(link.send_errors));
    }
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "doppel-teamcomm: " << error.what() << "\n";
    return 2;
  }
}
