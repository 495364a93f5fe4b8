#pragma once
// What `doppel-bus report` prints: the analysis and the what-if scenarios of one robot as an
// aligned text table for terminals, as JSON for scripts, and as PNG plots drawn by gnuplot (a
// Debian package, run as a separate process on a script and data files in a temporary directory).
// docs/analyzer.md shows an example. Allocates and writes files: not for real-time threads.

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "analyzer/analysis.h"
#include "analyzer/transaction.h"
#include "analyzer/what_if.h"

namespace doppel::analyzer {

struct Report {
  std::string source;            // the recording's file name ("" for in-memory traffic)
  Analysis analysis;
  std::vector<WhatIf> what_ifs;  // first: the recording's own settings
};

// One report per robot in `transactions` (each robot has its own driver and its own cycle), robots
// in index order: the analysis, then the recording's own settings and `scenarios` (none: the
// default list, default_scenarios). `source` names the file in the report.
std::vector<Report> make_reports(const recording::RunInfo& run, std::span<const Transaction> transactions,
                                 const std::string& source, const std::vector<Scenario>& scenarios = {});

// The transactions of the last `seconds` (by first_seen_ns, counted back from the latest one), for
// an analysis of only the most recent traffic (doppel-bus report --last). Time order is kept.
std::vector<Transaction> last_seconds(std::span<const Transaction> transactions, double seconds);

// How a scenario is shown: its settings, "model, recorded settings" for the recording's own.
std::string scenario_label(const WhatIf& what_if);

// The text summary: cycle, buses, time split per kind (mean, p50, p99 in µs), timeouts (at most
// `max_timeouts` listed), what-if table next to the recorded cycle.
std::string format_text(const Report& report, std::size_t max_timeouts = 10);

// What format_json adds for a viewer: each report's cycle periods over time ("period_series":
// {"t_s": [...], "period_us": [...], "per_point": k}), t_s the end of each period in seconds from
// `origin_ns` (the replay's recording time). Longer series are cut into buckets of k periods, each
// shown by its longest period at the time of its first one, so a spike is never averaged away.
struct JsonOptions {
  std::size_t period_points = 0;  // 0: no series
  int64_t origin_ns = 0;
};

// Every number of the reports as one JSON document: {"reports": [...]} (times in µs, rates in Hz).
std::string format_json(const std::vector<Report>& reports, const JsonOptions& options = {});

// gnuplot could not be started or failed; the message says what to do.
struct PlotError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Draws cycle_period.png (period over time), period_histogram.png, time_split.png (stacked bars
// per kind, mean µs) and what_if.png (rate per scenario) into `directory` (created when missing),
// each file name prefixed with `prefix`. Returns the files written. Throws PlotError when gnuplot
// is not on PATH (install gnuplot-nox) or fails, and std::runtime_error when the directory
// cannot be written, naming it. Plots without data (no cycle) are left out.
std::vector<std::string> write_plots(const Report& report, const std::string& directory, const std::string& prefix = "");

}  // namespace doppel::analyzer
