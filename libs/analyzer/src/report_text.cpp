#include <algorithm>
#include <cstdio>
#include <sstream>

#include "analyzer/report.h"

namespace doppel::analyzer {

namespace {

std::string fixed(double value, int decimals = 1) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

std::string us(double ns) { return fixed(ns / 1000.0); }

// A part of the time split: "-" when no transaction of the kind had it (e.g. no status).
std::string part_us(const Distribution& d, double Distribution::*field) { return d.count == 0 ? "-" : us(d.*field); }

std::string percent(double fraction) { return fixed(100.0 * fraction) + " %"; }

// Columns padded to their widest cell; the first `left` columns left-aligned, the rest right.
class Table {
 public:
  explicit Table(std::vector<std::string> header, std::size_t left = 1) : left_(left) { rows_.push_back(std::move(header)); }
  void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  std::string str() const {
    std::vector<std::size_t> width;
    for (const auto& row : rows_) {
      if (width.size() < row.size()) width.resize(row.size(), 0);
      for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
    }
    std::string out;
    for (const auto& row : rows_) {
      std::string line = "  ";
      for (std::size_t c = 0; c < row.size(); ++c) {
        const std::string pad(width[c] - row[c].size(), ' ');
        line += c < left_ ? row[c] + pad : pad + row[c];
        if (c + 1 < row.size()) line += "  ";
      }
      while (!line.empty() && line.back() == ' ') line.pop_back();
      out += line + "\n";
    }
    return out;
  }

 private:
  std::size_t left_;
  std::vector<std::vector<std::string>> rows_;
};

std::string cycle_line(const CycleStats& c) {
  if (!c.found) return "  no control cycle found (no request repeated at least 3 times)\n";
  std::ostringstream s;
  s << "  opener " << c.opener_kind << " on bus " << c.opener_bus << ": " << c.cycles << " cycle starts after "
    << c.startup_transactions << " start-up transactions\n";
  Table t({"", "mean us", "sd (jitter) us", "min us", "p50 us", "p99 us", "max us"});
  t.add({"period", us(c.period.mean_ns), us(c.period.stddev_ns), us(c.period.min_ns), us(c.period.p50_ns),
         us(c.period.p99_ns), us(c.period.max_ns)});
  t.add({"busy", us(c.busy.mean_ns), us(c.busy.stddev_ns), us(c.busy.min_ns), us(c.busy.p50_ns), us(c.busy.p99_ns),
         us(c.busy.max_ns)});
  s << t.str();
  s << "  rate " << fixed(c.rate_hz) << " Hz (1 / mean period)\n";
  return s.str();
}

}  // namespace

std::string format_text(const Report& report, std::size_t max_timeouts) {
  const Analysis& a = report.analysis;
  std::ostringstream s;
  s << "doppel-bus report";
  if (!report.source.empty()) s << ": " << report.source;
  s << ", robot " << a.robot;
  if (!a.robot_name.empty()) s << " (" << a.robot_name << ")";
  s << ", " << a.transactions << " transactions";
  if (!a.timing_mode.empty()) s << ", timing " << a.timing_mode;
  s << "\n";
  if (a.timing_mode == "fast") {
    s << "  note: recorded in fast timing: the wire times are not a real bus' (see docs/analyzer.md)\n";
  }

  s << "\nControl cycle" << (a.buses.size() > 1 ? " (all buses)" : "") << "\n" << cycle_line(a.cycle);

  s << "\nBuses\n";
  Table buses({"bus", "link", "baud", "transactions", "utilisation", "in loop", "cycle Hz", "period p50 us",
               "p99 us", "max us", "timeouts", "retries", "missing", "dropped replies"},
              2);
  for (const BusStats& b : a.buses) {
    buses.add({std::to_string(b.bus), b.link.empty() ? "-" : b.link, std::to_string(b.baud_bps),
               std::to_string(b.transactions), percent(b.utilisation), b.cycle.found ? percent(b.loop_utilisation) : "-",
               b.cycle.found ? fixed(b.cycle.rate_hz) : "-", b.cycle.found ? us(b.cycle.period.p50_ns) : "-",
               b.cycle.found ? us(b.cycle.period.p99_ns) : "-", b.cycle.found ? us(b.cycle.period.max_ns) : "-",
               std::to_string(b.timeouts), std::to_string(b.retries), std::to_string(b.missing_transactions),
               std::to_string(b.dropped_replies)});
  }
  s << buses.str();

  s << "\nTime split per transaction kind, us (host write + return delay + status wire + status gaps + adapter + "
       "Doppel late = total)\n";
  Table kinds({"kind", "count", "", "host write", "return delay", "status wire", "status gaps", "adapter",
               "Doppel late", "total"},
              3);
  for (const KindStats& k : a.kinds) {
    auto row = [&](const char* stat, double Distribution::*field) {
      kinds.add({std::string(stat) == "mean" ? k.kind : "", std::string(stat) == "mean" ? std::to_string(k.count) : "",
                 stat, part_us(k.host_write, field), part_us(k.return_delay, field), part_us(k.status_wire, field),
                 part_us(k.status_gaps, field), part_us(k.adapter, field), part_us(k.lateness, field),
                 part_us(k.total, field)});
    };
    row("mean", &Distribution::mean_ns);
    row("p50", &Distribution::p50_ns);
    row("p99", &Distribution::p99_ns);
  }
  s << kinds.str();

  s << "\nTimeouts: " << a.timeouts.size() << ", retries: " << a.retries << "\n";
  for (std::size_t i = 0; i < a.timeouts.size() && i < max_timeouts; ++i) {
    const TimeoutEvent& e = a.timeouts[i];
    s << "  bus " << e.bus << " #" << e.sequence << " " << e.kind << ": no status from ID";
    for (uint8_t id : e.missing_ids) s << " " << int{id};
    if (e.wait_ns >= 0) s << "; the driver went on after " << us(static_cast<double>(e.wait_ns)) << " us";
    if (e.retried) s << " with a retry";
    s << "\n";
  }
  if (a.timeouts.size() > max_timeouts) s << "  ... " << a.timeouts.size() - max_timeouts << " more\n";

  s << "\nWhat if (the recorded cycles through the wire model, the driver sending each instruction as soon as it "
       "has the previous reply)\n";
  Table w({"scenario", "buses", "cycles", "cycle mean us", "p50 us", "p99 us", "rate Hz"});
  if (a.cycle.found) {
    w.add({"measured (recorded periods)", std::to_string(a.buses.size()), std::to_string(a.cycle.cycles ? a.cycle.cycles - 1 : 0),
           us(a.cycle.period.mean_ns), us(a.cycle.period.p50_ns), us(a.cycle.period.p99_ns), fixed(a.cycle.rate_hz)});
    // The traffic part of each cycle: what the model's cycle compares with when the loop sleeps.
    w.add({"measured (recorded busy time)", std::to_string(a.buses.size()),
           std::to_string(a.cycle.cycles ? a.cycle.cycles - 1 : 0), us(a.cycle.busy.mean_ns), us(a.cycle.busy.p50_ns),
           us(a.cycle.busy.p99_ns), a.cycle.busy.mean_ns > 0 ? fixed(1e9 / a.cycle.busy.mean_ns) : "-"});
  }
  for (const WhatIf& x : report.what_ifs) {
    if (x.cycles == 0) {
      w.add({scenario_label(x), "-", "0", "-", "-", "-", x.note});
      continue;
    }
    w.add({scenario_label(x), std::to_string(x.buses), std::to_string(x.cycles), us(x.cycle.mean_ns), us(x.cycle.p50_ns),
           us(x.cycle.p99_ns), fixed(x.rate_hz)});
  }
  s << w.str();
  return s.str();
}

}  // namespace doppel::analyzer
