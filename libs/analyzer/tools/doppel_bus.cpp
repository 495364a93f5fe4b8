// doppel-bus: what a robot team's control loop costs on the bus, from a recording made with
// `doppel --record` (docs/analyzer.md).
//
//   doppel-bus report FILE.mcap [--png DIR] [--json] [--what-if baud=3000000,rdt=0,latency=1,buses=4 ...]
//                               [--bus ROBOT/BUS] [--progress] [--last SECONDS] [--follow SECONDS]
//
// --follow SECONDS reads the file of a running `doppel --record` again every SECONDS and prints the
// report again, until Ctrl-C or until doppel closes the file (a final report).
//
// Exit codes: 0 report written, 1 bad command line, 2 the file cannot be read (the message names
// it), 3 the plots could not be drawn (gnuplot missing or failing).
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <thread>
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
  double follow_s = 0.0;  // --follow: seconds between readings (0: read once)
  double last_s = 0.0;    // --last: only the most recent seconds (0: everything)
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

// The reports of one reading of the file (only the last --last seconds when asked).
std::vector<Report> make_file_reports(const Options& options, const Recording& recording) {
  std::vector<Scenario> scenarios;
  for (const std::string& text : options.what_if) scenarios.push_back(parse_scenario(text));
  if (options.last_s > 0.0) {
    const std::vector<Transaction> recent = last_seconds(recording.transactions, options.last_s);
    return make_reports(recording.run, recent, options.file, scenarios);
  }
  return make_reports(recording.run, recording.transactions, options.file, scenarios);
}

// Draws the plots when asked; false (message on stderr) when they could not be drawn.
bool draw_plots(const Options& options, const std::vector<Report>& reports, std::vector<std::string>& plots) {
  if (options.png_dir.empty()) return true;
  try {
    for (const Report& r : reports) {
      const std::string prefix = reports.size() > 1 ? "robot" + std::to_string(r.analysis.robot) + "_" : "";
      for (const std::string& f : write_plots(r, options.png_dir, prefix)) plots.push_back(f);
    }
  } catch (const std::exception& e) {
    std::cerr << "doppel-bus: " << e.what() << "\n";
    return false;
  }
  return true;
}

void print_text(const std::vector<Report>& reports) {
  for (std::size_t i = 0; i < reports.size(); ++i) std::cout << (i ? "\n" : "") << format_text(reports[i]);
}

// The line on stderr after a report: what was read and what was lost.
void print_summary(const Options& options, const Recording& recording, const std::vector<Report>& reports,
                   const std::vector<std::string>& plots, Clock::time_point start) {
  std::set<std::pair<uint32_t, uint32_t>> buses;
  std::set<uint32_t> robots;
  for (const auto& t : recording.transactions) {
    robots.insert(t.robot);
    buses.insert({t.robot, t.bus});
  }
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.2f", std::chrono::duration<double>(Clock::now() - start).count());
  std::cerr << "doppel-bus: read " << recording.messages << " messages (" << megabytes(recording.message_bytes) << " of a "
            << megabytes(recording.file_bytes) << " file) in " << seconds << " s: " << recording.transactions.size()
            << " transactions on " << buses.size() << " bus(es) of " << robots.size() << " robot(s)";
  if (options.last_s > 0.0) {
    uint64_t analysed = 0;
    for (const Report& r : reports) analysed += r.analysis.transactions;
    std::cerr << " (" << analysed << " of them in the last " << options.last_s << " s analysed)";
  }
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
}

int report(const Options& options) {
  std::optional<BusSelector> only;
  if (!options.bus.empty()) only = parse_bus_selector(options.bus);

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

  const std::vector<Report> reports = make_file_reports(options, recording);
  if (options.json) {
    std::cout << format_json(reports);
  } else {
    print_text(reports);
  }
  std::vector<std::string> plots;
  if (!draw_plots(options, reports, plots)) return 3;
  print_summary(options, recording, reports, plots, start);
  return 0;
}

volatile sig_atomic_t g_stop = 0;

// Sleeps `seconds` in short steps; false when SIGINT / SIGTERM came.
bool wait_unless_stopped(double seconds) {
  const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  while (!g_stop && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return !g_stop;
}

// --follow: the file a running `doppel --record` writes, read again every options.follow_s seconds
// (mcap::Reader reads its finished chunks; the recorder finishes one every second), until SIGINT
// or SIGTERM (exit 0) or until doppel has closed the file (a final report, exit 0).
int follow(const Options& options) {
  std::optional<BusSelector> only;
  if (!options.bus.empty()) only = parse_bus_selector(options.bus);
  struct sigaction action {};
  action.sa_handler = [](int) { g_stop = 1; };
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  const bool terminal = ::isatty(STDOUT_FILENO) == 1;
  bool said_waiting = false;
  uint64_t round = 0;
  auto say_once = [&](const std::string& text) {
    if (said_waiting) return;
    said_waiting = true;
    std::cerr << "doppel-bus: " << text << "\n";
  };
  while (!g_stop) {
    const auto start = Clock::now();
    std::error_code error;
    const bool exists = std::filesystem::exists(options.file, error);
    if (!exists || std::filesystem::file_size(options.file, error) == 0 || error) {
      say_once("waiting for " + options.file + " to appear (is doppel --record " + options.file + " running?)");
      wait_unless_stopped(std::min(options.follow_s, 0.2));
      continue;
    }
    Recording recording;
    try {
      recording = read_recording(options.file, only, {}, false);
    } catch (const std::exception& e) {
      std::cerr << "doppel-bus: " << e.what() << "\n";
      return 2;
    }
    if (recording.transactions.empty()) {
      if (recording.complete) {
        std::cerr << "doppel-bus: " << options.file
                  << ": the recording is complete and holds no bus transactions (topics /doppel/bus/<robot>/<bus>/transactions)\n";
        return 2;
      }
      say_once("waiting for bus transactions in " + options.file + " (the recorder writes its first chunk after a second)");
      wait_unless_stopped(std::min(options.follow_s, 0.2));
      continue;
    }
    const std::vector<Report> reports = make_file_reports(options, recording);
    ++round;
    const int64_t first = recording.transactions.front().first_seen_ns;
    const int64_t last = recording.transactions.back().first_seen_ns;
    char heading[512];
    std::snprintf(heading, sizeof heading, "doppel-bus --follow %s: report %llu, %.1f s of traffic, %s, %s", options.file.c_str(),
                  static_cast<unsigned long long>(round), static_cast<double>(last - first) / 1e9,
                  megabytes(recording.file_bytes).c_str(),
                  recording.complete ? "complete (doppel closed it): final report" : "still being written");
    if (terminal) {
      std::cout << "\x1b[H\x1b[2J" << heading << "\n\n";  // cursor home, clear the screen
    } else {
      std::cout << (round > 1 ? "\n" : "") << "---- " << heading << " ----\n";
    }
    print_text(reports);
    std::cout.flush();
    std::vector<std::string> plots;
    if (!draw_plots(options, reports, plots)) return 3;
    if (recording.complete) {
      print_summary(options, recording, reports, plots, start);
      return 0;
    }
    wait_unless_stopped(options.follow_s);
  }
  std::cerr << "doppel-bus: stopped (" << round << " reports)\n";
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
  auto* follow_option =
      cmd->add_option("--follow", options.follow_s,
                      "the recording a running doppel --record writes: report again every SECONDS until Ctrl-C or until "
                      "doppel closes the file (then a final report); waits for the file to appear")
          ->check(CLI::Range(0.1, 3600.0));
  cmd->add_option("--last", options.last_s, "analyse only the most recent SECONDS of traffic")->check(CLI::Range(0.01, 1e9));
  follow_option->excludes(cmd->get_option("--json"))->excludes(cmd->get_option("--progress"));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 1;
  }
  try {
    return options.follow_s > 0.0 ? follow(options) : report(options);
  } catch (const std::exception& e) {
    std::cerr << "doppel-bus: " << e.what() << "\n";
    return 1;
  }
}
