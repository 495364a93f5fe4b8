#include <nlohmann/json.hpp>

#include <algorithm>

#include "analyzer/report.h"

namespace doppel::analyzer {

namespace {

using nlohmann::json;

json distribution(const Distribution& d) {
  return json{{"count", d.count},         {"mean_us", d.mean_ns / 1e3}, {"stddev_us", d.stddev_ns / 1e3},
              {"min_us", d.min_ns / 1e3}, {"p50_us", d.p50_ns / 1e3},   {"p99_us", d.p99_ns / 1e3},
              {"max_us", d.max_ns / 1e3}};
}

json cycle(const CycleStats& c) {
  if (!c.found) return json{{"found", false}};
  return json{{"found", true},
              {"opener_kind", c.opener_kind},
              {"opener_signature", c.opener_signature},
              {"opener_bus", c.opener_bus},
              {"cycles", c.cycles},
              {"startup_transactions", c.startup_transactions},
              {"first_start_ns", c.first_start_ns},
              {"last_start_ns", c.last_start_ns},
              {"period", distribution(c.period)},
              {"busy", distribution(c.busy)},
              {"rate_hz", c.rate_hz}};
}

json period_series(const CycleStats& c, const JsonOptions& options) {
  json t_s = json::array();
  json period_us = json::array();
  const std::size_t periods = c.starts_ns.size() < 2 ? 0 : c.starts_ns.size() - 1;
  const std::size_t per_point = std::max<std::size_t>(1, (periods + options.period_points - 1) / options.period_points);
  for (std::size_t first = 0; first < periods; first += per_point) {
    int64_t longest = 0;
    for (std::size_t i = first; i < std::min(periods, first + per_point); ++i) {
      longest = std::max(longest, c.starts_ns[i + 1] - c.starts_ns[i]);
    }
    t_s.push_back(static_cast<double>(c.starts_ns[first + 1] - options.origin_ns) / 1e9);
    period_us.push_back(static_cast<double>(longest) / 1e3);
  }
  return json{{"t_s", std::move(t_s)}, {"period_us", std::move(period_us)}, {"per_point", per_point}};
}

json report(const Report& r, const JsonOptions& options) {
  const Analysis& a = r.analysis;
  json buses = json::array();
  for (const BusStats& b : a.buses) {
    buses.push_back(json{{"bus", b.bus},
                         {"link", b.link},
                         {"baud_bps", b.baud_bps},
                         {"transactions", b.transactions},
                         {"missing_transactions", b.missing_transactions},
                         {"dropped_replies", b.dropped_replies},
                         {"span_us", static_cast<double>(b.span_ns) / 1e3},
                         {"busy_us", static_cast<double>(b.busy_ns) / 1e3},
                         {"utilisation", b.utilisation},
                         {"loop_utilisation", b.loop_utilisation},
                         {"timeouts", b.timeouts},
                         {"retries", b.retries},
                         {"timeout_wait", distribution(b.timeout_wait)},
                         {"cycle", cycle(b.cycle)}});
  }
  json kinds = json::array();
  for (const KindStats& k : a.kinds) {
    kinds.push_back(json{{"kind", k.kind},
                         {"count", k.count},
                         {"answered", k.answered},
                         {"statuses", k.statuses},
                         {"timeouts", k.timeouts},
                         {"retries", k.retries},
                         {"bad_checksums", k.bad_checksums},
                         {"host_write", distribution(k.host_write)},
                         {"return_delay", distribution(k.return_delay)},
                         {"status_wire", distribution(k.status_wire)},
                         {"status_gaps", distribution(k.status_gaps)},
                         {"adapter", distribution(k.adapter)},
                         {"lateness", distribution(k.lateness)},
                         {"total", distribution(k.total)}});
  }
  json timeouts = json::array();
  for (const TimeoutEvent& e : a.timeouts) {
    timeouts.push_back(json{{"bus", e.bus},
                            {"sequence", e.sequence},
                            {"time_ns", e.time_ns},
                            {"kind", e.kind},
                            {"missing_ids", e.missing_ids},
                            {"wait_us", e.wait_ns < 0 ? json(nullptr) : json(static_cast<double>(e.wait_ns) / 1e3)},
                            {"retried", e.retried}});
  }
  json what_ifs = json::array();
  for (const WhatIf& w : r.what_ifs) {
    json x{{"scenario", w.label}, {"buses", w.buses}, {"cycles", w.cycles}};
    if (w.cycles > 0) {
      x["cycle"] = distribution(w.cycle);
      x["rate_hz"] = w.rate_hz;
    } else {
      x["note"] = w.note;
    }
    what_ifs.push_back(std::move(x));
  }
  json out{{"source", r.source},
              {"robot", a.robot},
              {"robot_name", a.robot_name},
              {"timing_mode", a.timing_mode},
              {"transactions", a.transactions},
              {"cycle", cycle(a.cycle)},
              {"buses", std::move(buses)},
              {"kinds", std::move(kinds)},
              {"timeouts", std::move(timeouts)},
              {"retries", a.retries},
              {"what_if", std::move(what_ifs)}};
  if (options.period_points > 0 && a.cycle.found) out["period_series"] = period_series(a.cycle, options);
  return out;
}

}  // namespace

std::string scenario_label(const WhatIf& what_if) {
  return what_if.label == "recorded" ? "model, recorded settings" : what_if.label;
}

std::string format_json(const std::vector<Report>& reports, const JsonOptions& options) {
  json list = json::array();
  for (const Report& r : reports) list.push_back(report(r, options));
  return json{{"reports", std::move(list)}}.dump(2) + "\n";
}

}  // namespace doppel::analyzer
