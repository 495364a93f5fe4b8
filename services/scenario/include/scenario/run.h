#pragma once
// `doppel scenario run`: one scenario, headless (no camera, no viewer), in this process: the
// gateway serves the robots' links in a private link directory, the controller runs as a child
// process, the schedule is applied on the simulation thread at its simulation times, and the
// result is one JSON object (docs/scenarios.md). Setup errors throw std::runtime_error or
// std::invalid_argument with a message for the user.

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scenario/scenario.h"

namespace doppel::scenario {

struct RunOptions {
  std::optional<uint64_t> seed;                // --seed; unset: the file's
  std::map<std::string, std::string> params;   // --param NAME=VALUE
  std::optional<double> duration_s;            // --duration: overrides the file's
  std::string work_dir;                        // links, recording, controller output; "" = a fresh temp dir, removed after
  std::vector<std::string> tool_dirs;          // where bare program names are looked up first
  std::ostream* progress = nullptr;            // progress lines (null: none)
  bool progress_terminal = false;              // rewrite one line (\r) instead of a line per second
  int stop_signal_poll_ms = 20;
};

// Runs `scenario` and returns its result. `stop_requested` (may be null) is polled: when it turns
// true (SIGINT/SIGTERM) the run ends early with "ended": "stopped".
nlohmann::json run_scenario(const Scenario& scenario, const RunOptions& options,
                            const std::atomic<bool>* stop_requested = nullptr);

// The tool folders of this build: beside the running executable, and the build tree's doppel-run
// and doppel-walk folders when they exist.
std::vector<std::string> default_tool_dirs();

// The `doppel scenario ...` command line (argv[0] = "scenario"). Returns the exit code: 0 the run
// finished (its result on `out`), 1 it could not run (the reason on `err`), 2 bad usage.
int scenario_main(int argc, char** argv, std::ostream& out, std::ostream& err);

}  // namespace doppel::scenario
