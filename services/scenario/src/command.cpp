#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <atomic>
#include <iostream>
#include <thread>

#include "base/command_line.h"
#include "base/stop_signals.h"
#include "gateway/robot_config.h"
#include "scenario/run.h"

namespace doppel::scenario {

int scenario_main(int argc, char** argv, std::ostream& out, std::ostream& err) {
  CLI::App app("Runs scenario files: robots, a schedule of pushes and ball moves, a controller, metrics "
               "(docs/scenarios.md).",
               "doppel scenario");
  app.require_subcommand(1);
  CLI::App* run = app.add_subcommand("run", "Run FILE headless and print one JSON result on stdout.");
  std::string file, robots_dir, work_dir;
  uint64_t seed = 0;
  std::vector<std::string> params;
  double duration_s = 0.0;
  bool progress = false;
  run->add_option("FILE", file, "scenario file (protobuf text, libs/proto/scenario.proto)")->required();
  run->add_option("--seed", seed, "seed of the schedule's random times and the controller's {seed} (default: the file's)");
  run->add_option("--param", params, "NAME=VALUE for the controller's {param:NAME} (repeatable)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  run->add_option("--duration", duration_s, "simulated seconds, instead of the file's duration_s")
      ->transform(number_in<double>(0.001, kMaxDurationS));
  run->add_option("--robots-dir", robots_dir, "where robot names are looked up (default: doppel's data/robots/)");
  run->add_option("--work-dir", work_dir,
                  "keep the run's links, recording and controller output here (default: a temporary directory, removed)");
  run->add_flag("--progress", progress,
                "a progress line on stderr every simulated second also when stderr is not a terminal");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    out << app.help();
    return 0;
  } catch (const CLI::CallForAllHelp&) {
    out << app.help("", CLI::AppFormatMode::All);
    return 0;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {
      out << (run->parsed() ? run->help() : app.help());
      return 0;
    }
    err << "doppel scenario: " << e.what() << " (see doppel scenario run --help)\n";
    return 2;
  }

  // SIGINT/SIGTERM end the run early (controller stopped, result printed), as at the duration.
  const sigset_t stop_signals = block_stop_signals();
  static std::atomic<bool> stop{false};
  std::thread([stop_signals] {
    int number = 0;
    sigwait(&stop_signals, &number);
    stop.store(true);
  }).detach();

  try {
    const Scenario scenario =
        load_scenario(file, robots_dir.empty() ? gateway::default_robots_dir() : robots_dir);
    RunOptions options;
    if (run->count("--seed") > 0) options.seed = seed;
    if (run->count("--duration") > 0) options.duration_s = duration_s;
    for (const std::string& param : params) {
      const auto [name, value] = parse_param(param);
      options.params[name] = value;
    }
    options.work_dir = work_dir;
    options.tool_dirs = default_tool_dirs();
    const bool terminal = ::isatty(STDERR_FILENO) == 1;
    if (terminal || progress) {
      options.progress = &err;
      options.progress_terminal = terminal;
    }
    const nlohmann::json result = run_scenario(scenario, options, &stop);
    out << result.dump() << "\n" << std::flush;
  } catch (const std::exception& e) {
    err << "doppel scenario: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace doppel::scenario
