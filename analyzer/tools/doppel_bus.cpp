// doppel-bus: what a robot team's control loop costs on the bus, from a recording made with
// `doppel --record` (docs/analyzer.md).
//
//   doppel-bus report FILE.mcap [--png DIR] [--json] [--what-if baud=3000000,rdt=0,latency=1,buses=4 ...]
//                               [--bus ROBOT/BUS] [--progress]
//
// Exit codes: 0 report written, 1 bad command line, 2 the file cannot be read (the message names
// it), 3 the plots could not be drawn (gnuplot missing or failing).
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "analyzer/analysis.h"
#include "analyzer/recording_reader.h"
#include "analyzer/report.h"
#include "analyzer/what_if.h"

namespace {

using namespace doppel::analyzer;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string file;
  std::string png_dir;
  bool json = false;
  bool progress = false;
  std::vector<std::string> what_if;
  std::string bus;
};

std::string megabytes(uint64_t bytes) {
  char buffer[32];
  if (bytes < 1'000'000) {
    std::snprintf(buffer, sizeof buffer, "%.1f kB", static_cast<double>(bytes) / 1e3);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.1f MB", static_cast<double>(bytes) / 1e6);
  }
  return buffer;
}

int report(const Options& options) {
  std::optional<BusSelector> only;
  if (!options.bus.empty()) only = parse_bus_selector(options.bus);
  std::vector<Scenario> scenarios;
  for (const std::string& text : options.what_if) scenarios.push_back(parse_scenario(text));

  // A progress line on a terminal (or when asked), at most 4 times a second.
  const bool show_progress = options.progress || ::isatty(STDERR_FILENO) == 1;
  const auto start = Clock::now();
  auto last_shown = start;
  bool shown = false;
  auto on_progress = [&](const ReadProgress& p) {
    const auto now = Clock::now();
    if (now - last_shown < std::chrono::milliseconds(250)) return;
    last_shown = now;
    shown = true;
    std::fprintf(stderr, "\rreading %s: %llu", options.file.c_str(), static_cast<unsigned long long>(p.messages));
    if (p.total_messages > 0) std::fprintf(stderr, " / %llu", static_cast<unsigned long long>(p.total_messages));
    std::fprintf(stderr, " messages, %s   ", megabytes(p.message_bytes).c_str());
    std::fflush(stderr);
  };

  Recording recording;
  try {
    recording = read_recording(options.file, only, show_progress ? std::function<void(const ReadProgress&)>(on_progress)
                                                                 : std::function<void(const ReadProgress&)>());
  } catch (const std::exception& e) {
    if (shown) std::fputs("\n", stderr);
    std::cerr << "doppel-bus: " << e.what() << "\n";
    return 2;
  }
  if (shown) std::fputs("\n", stderr);
  if (!recording.recovery_note.empty()) std::cerr << "doppel-bus: " << options.file << ": " << recording.recovery_note << "\n";

  // One report per robot: each robot has its own driver and its own control cycle.
  std::set<uint32_t> robots;
  std::set<std::pair<uint32_t, uint32_t>> buses;
  for (const auto& t : recording.transactions) {
    robots.insert(t.robot);
    buses.insert({t.robot, t.bus});
  }
  std::vector<Report> reports;
  for (uint32_t robot : robots) {
    Report r;
    r.source = options.file;
    r.analysis = analyze(recording.run, recording.transactions, robot);
    const std::vector<Scenario> list = scenarios.empty() ? default_scenarios(recording.run, r.analysis) : [&] {
      std::vector<Scenario> with_recorded{Scenario{}};
      with_recorded.insert(with_recorded.end(), scenarios.begin(), scenarios.end());
      return with_recorded;
    }();
    for (const Scenario& s : list) r.what_ifs.push_back(what_if(recording.run, recording.transactions, r.analysis, s));
    reports.push_back(std::move(r));
  }

  if (options.json) {
    std::cout << format_json(reports);
  } else {
    for (std::size_t i = 0; i < reports.size(); ++i) std::cout << (i ? "\n" : "") << format_text(reports[i]);
  }

  std::vector<std::string> plots;
  if (!options.png_dir.empty()) {
    try {
      for (const Report& r : reports) {
        const std::string prefix = reports.size() > 1 ? "robot" + std::to_string(r.analysis.robot) + "_" : "";
        for (const std::string& f : write_plots(r, options.png_dir, prefix)) plots.push_back(f);
      }
    } catch (const std::exception& e) {
      std::cerr << "doppel-bus: " << e.what() << "\n";
      return 3;
    }
  }

  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.2f", std::chrono::duration<double>(Clock::now() - start).count());
  std::cerr << "doppel-bus: read " << recording.messages << " messages (" << megabytes(recording.message_bytes) << " of a "
            << megabytes(recording.file_bytes) << " file) in " << seconds << " s: " << recording.transactions.size()
            << " transactions on " << buses.size() << " bus(es) of " << robots.size() << " robot(s)";
  uint64_t missing = 0;
  for (const Report& r : reports) {
    for (const BusStats& b : r.analysis.buses) missing += b.missing_transactions;
  }
  std::cerr << "; " << missing << " transactions missing (sequence gaps)";
  if (recording.have_summary) {
    std::cerr << "; the recorder dropped " << recording.summary.dropped_messages() << " messages and "
              << recording.summary.dropped_bus_events() << " bus events";
  }
  if (!plots.empty()) std::cerr << "; " << plots.size() << " plots in " << options.png_dir;
  std::cerr << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"doppel-bus: what a control loop costs on the Dynamixel bus, from a doppel --record recording"};
  app.require_subcommand(1);
  Options options;
  CLI::App* cmd = app.add_subcommand("report", "analyse a recording: control cycle, time split, timeouts, what if");
  cmd->add_option("file", options.file, "recording written by doppel --record (MCAP)")->required();
  cmd->add_option("--png", options.png_dir, "draw PNG plots with gnuplot into this directory");
  cmd->add_flag("--json", options.json, "print JSON instead of the text summary");
  cmd->add_option("--what-if", options.what_if,
                  "scenario key=value[,key=value...]: baud, rdt (us), fw (us), latency (ms), adapter (ftdi|usb2ax), "
                  "driver=recorded, "
                  "buses; repeat for several (default: a few usual remedies)")
      ->check(CLI::Validator(
          [](std::string& text) {
            try {
              parse_scenario(text);
              return std::string();
            } catch (const std::exception& e) {
              return std::string(e.what());
            }
          },
          "SCENARIO"));
  cmd->add_option("--bus", options.bus, "only this bus, ROBOT/BUS (e.g. 0/1)")
      ->check(CLI::Validator(
          [](std::string& text) {
            try {
              parse_bus_selector(text);
              return std::string();
            } catch (const std::exception& e) {
              return std::string(e.what());
            }
          },
          "ROBOT/BUS"));
  cmd->add_flag("--progress", options.progress, "show the progress line also when stderr is not a terminal");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 1;
  }
  try {
    return report(options);
  } catch (const std::exception& e) {
    std::cerr << "doppel-bus: " << e.what() << "\n";
    return 1;
  }
}
