#include "analyzer/analysis.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <unordered_map>

#include "analyzer/instruction.h"
#include "dynamixel/packet.h"

namespace doppel::analyzer {

namespace ins = dynamixel::instruction;


namespace {

std::span<const uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// When the driver had everything of this transaction it was going to get.
int64_t done_ns(const Transaction& t) {
  return std::max({t.seen_ns, t.instruction_end_ns, t.due_ns, t.written_ns});
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

Distribution summarize(std::vector<double> values) {
  Distribution d;
  if (values.empty()) return d;
  std::sort(values.begin(), values.end());
  d.count = values.size();
  double sum = 0.0;
  for (double v : values) sum += v;
  d.mean_ns = sum / static_cast<double>(values.size());
  double square = 0.0;
  for (double v : values) square += (v - d.mean_ns) * (v - d.mean_ns);
  d.stddev_ns = std::sqrt(square / static_cast<double>(values.size()));
  auto rank = [&](double q) {
    const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
    return values[std::clamp<std::size_t>(k, 1, values.size()) - 1];
  };
  d.min_ns = values.front();
  d.p50_ns = rank(0.50);
  d.p99_ns = rank(0.99);
  d.max_ns = values.back();
  return d;
}

CycleStats find_cycle(std::span<const Transaction* const> transactions, bool with_bus) {
  CycleStats cycle;
  struct Candidate {
    std::vector<std::size_t> at;  // indexes into transactions
    std::vector<double> idle_ns;  // idle time before each occurrence
  };
  std::unordered_map<std::string, Candidate> by_signature;
  std::vector<std::string> signatures(transactions.size());
  std::map<uint32_t, int64_t> previous_done;  // per bus: a driver's thread per bus idles on its own
  for (std::size_t i = 0; i < transactions.size(); ++i) {
    const Transaction& t = *transactions[i];
    std::string s = signature(decode_instruction(t.protocol, bytes_of(t.instruction)));
    if (with_bus) s = "bus " + std::to_string(t.bus) + ": " + s;
    Candidate& c = by_signature[s];
    c.at.push_back(i);
    const auto previous = previous_done.find(t.bus);
    if (previous != previous_done.end()) {
      c.idle_ns.push_back(static_cast<double>(std::max<int64_t>(0, t.first_seen_ns - previous->second)));
      previous->second = std::max(previous->second, done_ns(t));
    } else {
      previous_done[t.bus] = done_ns(t);
    }
    signatures[i] = std::move(s);
  }
  std::size_t most = 0;
  for (const auto& [s, c] : by_signature) most = std::max(most, c.at.size());
  if (most < 3) return cycle;
  const std::size_t least = std::max<std::size_t>(3, (most + 7) / 8);
  struct Scored {
    const std::string* signature;
    const Candidate* candidate;
    double idle_ns;
  };
  std::vector<Scored> scored;
  double best_idle = 0.0;
  for (const auto& [s, c] : by_signature) {
    if (c.at.size() < least) continue;
    scored.push_back({&s, &c, median(c.idle_ns)});
    best_idle = std::max(best_idle, scored.back().idle_ns);
  }
  const Scored* chosen = nullptr;
  for (const Scored& s : scored) {
    if (s.idle_ns < 0.5 * best_idle) continue;
    if (chosen == nullptr || s.candidate->at.size() < chosen->candidate->at.size() ||
        (s.candidate->at.size() == chosen->candidate->at.size() && s.candidate->at.front() < chosen->candidate->at.front())) {
      chosen = &s;
    }
  }
  const std::vector<std::size_t>& at = chosen->candidate->at;
  const Transaction& opener = *transactions[at.front()];
  cycle.found = true;
  cycle.opener_kind = kind_name(opener.protocol, decode_instruction(opener.protocol, bytes_of(opener.instruction)).code);
  cycle.opener_signature = *chosen->signature;
  cycle.opener_bus = opener.bus;
  std::vector<int64_t> starts;
  for (std::size_t k : at) starts.push_back(transactions[k]->first_seen_ns);
  set_cycle_starts(cycle, transactions, std::move(starts));
  return cycle;
}

void set_cycle_starts(CycleStats& cycle, std::span<const Transaction* const> transactions, std::vector<int64_t> starts) {
  std::sort(starts.begin(), starts.end());
  cycle.starts_ns = std::move(starts);
  const auto& st = cycle.starts_ns;
  cycle.cycles = st.size();
  if (st.empty()) return;
  cycle.first_start_ns = st.front();
  cycle.last_start_ns = st.back();
  std::vector<int64_t> end(st.begin(), st.end());
  cycle.startup_transactions = 0;
  for (const Transaction* t : transactions) {
    const auto next = std::upper_bound(st.begin(), st.end(), t->first_seen_ns);
    if (next == st.begin()) {
      ++cycle.startup_transactions;
      continue;
    }
    int64_t& e = end[static_cast<std::size_t>(next - st.begin()) - 1];
    e = std::max(e, done_ns(*t));
  }
  std::vector<double> periods;
  std::vector<double> busy;
  for (std::size_t k = 1; k < st.size(); ++k) {
    periods.push_back(static_cast<double>(st[k] - st[k - 1]));
    busy.push_back(static_cast<double>(end[k - 1] - st[k - 1]));
  }
  cycle.period = summarize(std::move(periods));
  cycle.busy = summarize(std::move(busy));
  cycle.rate_hz = cycle.period.mean_ns > 0 ? 1e9 / cycle.period.mean_ns : 0.0;
}

std::size_t nearest_start(std::span<const int64_t> starts, int64_t t_ns) {
  const auto it = std::lower_bound(starts.begin(), starts.end(), t_ns);
  if (it == starts.begin()) return 0;
  if (it == starts.end()) return starts.size() - 1;
  const auto k = static_cast<std::size_t>(it - starts.begin());
  return (t_ns - starts[k - 1] <= starts[k] - t_ns) ? k - 1 : k;
}

std::vector<uint8_t> expected_status_ids(const Transaction& t, const std::function<bool(uint8_t)>& answers_writes) {
  std::vector<uint8_t> ids;
  if (!t.checksum_ok) return ids;
  const Instruction in = decode_instruction(t.protocol, bytes_of(t.instruction));
  if (!in.framed) return ids;
  if (in.protocol == 1 && in.code == kUsb2axSyncRead) {
    ids.push_back(0xFD);  // the adapter answers with one status of its own
    return ids;
  }
  if (is_multi_device(in.protocol, in.code)) {
    if (!is_read(in.protocol, in.code)) return ids;
    for (const Addressed& a : addressed_devices(in)) ids.push_back(a.id);
    return ids;
  }
  if (in.id == dynamixel::kBroadcastId) return ids;
  if (in.code == ins::kPing || in.code == ins::kRead || answers_writes(in.id)) ids.push_back(in.id);
  return ids;
}

Analysis analyze(const recording::RunInfo& run, std::span<const recording::BusTransaction> messages, uint32_t robot) {
  const std::vector<Transaction> transactions = compact(messages);
  return analyze(run, transactions, robot);
}

Analysis analyze(const recording::RunInfo& run, std::span<const Transaction> all, uint32_t robot) {
  Analysis a;
  a.robot = robot;
  a.timing_mode = run.timing_mode();
  std::vector<const Transaction*> order;
  for (const Transaction& t : all) {
    if (t.robot == robot) order.push_back(&t);
  }
  std::stable_sort(order.begin(), order.end(), [](const Transaction* x, const Transaction* y) {
    if (x->first_seen_ns != y->first_seen_ns) return x->first_seen_ns < y->first_seen_ns;
    if (x->bus != y->bus) return x->bus < y->bus;
    return x->sequence < y->sequence;
  });
  a.transactions = order.size();
  for (const auto& info : run.buses()) {
    if (info.robot() == robot) a.robot_name = info.robot_name();
  }

  // Per bus, in wire order.
  std::map<uint32_t, std::vector<const Transaction*>> by_bus;
  for (const Transaction* t : order) by_bus[t->bus].push_back(t);

  // Which devices answer non-read instructions (Status Return Level 2): learned from the recording.
  std::set<std::pair<uint32_t, uint8_t>> answers_writes;
  for (const Transaction* t : order) {
    const Instruction in = decode_instruction(t->protocol, bytes_of(t->instruction));
    if (in.framed && in.id != dynamixel::kBroadcastId && !is_read(in.protocol, in.code) && !is_multi_device(in.protocol, in.code)) {
      for (const auto& s : t->statuses) {
        if (s.id == in.id) answers_writes.insert({t->bus, in.id});
      }
    }
  }

  std::map<std::string, KindStats> kinds;
  struct Parts {
    std::vector<double> host_write, return_delay, status_wire, status_gaps, adapter, lateness, total;
  };
  std::map<std::string, Parts> parts;

  for (auto& [bus_index, list] : by_bus) {
    BusStats b;
    b.robot = robot;
    b.bus = bus_index;
    for (const auto& info : run.buses()) {
      if (info.robot() == robot && info.bus() == bus_index) b.link = info.link();
    }
    b.transactions = list.size();
    b.cycle = find_cycle(list, false);
    int64_t first = INT64_MAX;
    int64_t last = INT64_MIN;
    int64_t loop_busy = 0;
    std::vector<double> waits;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Transaction& t = *list[i];
      if (i > 0 && t.sequence > list[i - 1]->sequence + 1) b.missing_transactions += t.sequence - list[i - 1]->sequence - 1;
      if (t.reply_dropped) ++b.dropped_replies;
      b.baud_bps = t.baud_bps;
      int64_t wire = t.instruction_end_ns - t.instruction_start_ns;
      first = std::min(first, t.instruction_start_ns);
      last = std::max(last, t.instruction_end_ns);
      for (const auto& s : t.statuses) {
        wire += s.end_ns - s.start_ns;
        last = std::max(last, s.end_ns);
      }
      b.busy_ns += wire;
      if (b.cycle.found && t.first_seen_ns >= b.cycle.first_start_ns && t.first_seen_ns < b.cycle.last_start_ns) loop_busy += wire;

      // Its kind; timeouts (an expected status missing) and retries (the same bytes right after).
      const Instruction in = decode_instruction(t.protocol, bytes_of(t.instruction));
      const std::string kind = in.framed ? kind_name(t.protocol, in.code) : "P" + std::to_string(t.protocol) + " unframed";
      KindStats& k = kinds[kind];
      Parts& p = parts[kind];
      k.kind = kind;
      ++k.count;
      if (!t.checksum_ok) ++k.bad_checksums;
      if (t.statuses.size() > 0) {
        ++k.answered;
        k.statuses += static_cast<uint64_t>(t.statuses.size());
      }
      const uint32_t bus = t.bus;
      const std::vector<uint8_t> expected =
          expected_status_ids(t, [&](uint8_t id) { return answers_writes.count({bus, id}) != 0; });
      TimeoutEvent e;
      for (uint8_t id : expected) {
        const bool got = std::any_of(t.statuses.begin(), t.statuses.end(), [&](const auto& s) { return s.id == id; });
        if (!got) e.missing_ids.push_back(id);
      }
      if (!e.missing_ids.empty() && !t.reply_dropped) {
        e.bus = bus;
        e.sequence = t.sequence;
        e.time_ns = t.first_seen_ns;
        e.kind = kind;
        if (i + 1 < list.size()) {
          const Transaction& next = *list[i + 1];
          e.wait_ns = next.first_seen_ns - std::max(t.instruction_end_ns, t.due_ns);
          e.retried = next.instruction == t.instruction;
          waits.push_back(static_cast<double>(e.wait_ns));
        }
        ++k.timeouts;
        ++b.timeouts;
        if (e.retried) {
          ++k.retries;
          ++b.retries;
          ++a.retries;
        }
        a.timeouts.push_back(std::move(e));
        continue;  // its time is its wait (TimeoutEvent), not part of the split
      }

      // Time split of this transaction.
      p.host_write.push_back(static_cast<double>(t.instruction_end_ns - t.first_seen_ns));
      if (t.statuses.size() == 0) {
        p.total.push_back(static_cast<double>(t.instruction_end_ns - t.first_seen_ns));
        continue;
      }
      const auto& first_status = t.statuses[0];
      const auto& last_status = t.statuses[t.statuses.size() - 1];
      int64_t status_wire = 0;
      for (const auto& s : t.statuses) status_wire += s.end_ns - s.start_ns;
      p.return_delay.push_back(static_cast<double>(first_status.start_ns - t.instruction_end_ns));
      p.status_wire.push_back(static_cast<double>(status_wire));
      p.status_gaps.push_back(static_cast<double>(last_status.end_ns - first_status.start_ns - status_wire));
      if (t.due_ns != 0) p.adapter.push_back(static_cast<double>(t.due_ns - last_status.end_ns));
      if (t.due_ns != 0 && t.written_ns != 0) p.lateness.push_back(static_cast<double>(t.written_ns - t.due_ns));
      const int64_t end = t.written_ns != 0 ? t.written_ns : t.due_ns;
      if (end != 0) p.total.push_back(static_cast<double>(end - t.first_seen_ns));
    }
    if (!list.empty() && last > first) {
      b.span_ns = last - first;
      b.utilisation = static_cast<double>(b.busy_ns) / static_cast<double>(b.span_ns);
    }
    if (b.cycle.found && b.cycle.last_start_ns > b.cycle.first_start_ns) {
      b.loop_utilisation = static_cast<double>(loop_busy) / static_cast<double>(b.cycle.last_start_ns - b.cycle.first_start_ns);
    }
    b.timeout_wait = summarize(std::move(waits));
    a.buses.push_back(std::move(b));
  }
  std::sort(a.timeouts.begin(), a.timeouts.end(), [](const TimeoutEvent& x, const TimeoutEvent& y) { return x.time_ns < y.time_ns; });

  for (auto& [name, k] : kinds) {
    Parts& p = parts[name];
    k.host_write = summarize(std::move(p.host_write));
    k.return_delay = summarize(std::move(p.return_delay));
    k.status_wire = summarize(std::move(p.status_wire));
    k.status_gaps = summarize(std::move(p.status_gaps));
    k.adapter = summarize(std::move(p.adapter));
    k.lateness = summarize(std::move(p.lateness));
    k.total = summarize(std::move(p.total));
    a.kinds.push_back(k);
  }
  std::stable_sort(a.kinds.begin(), a.kinds.end(), [](const KindStats& x, const KindStats& y) { return x.count > y.count; });

  if (a.buses.size() == 1) {
    a.cycle = a.buses.front().cycle;
  } else {
    a.cycle = find_cycle(order, true);
    // Each cycle starts when its first bus starts it (a driver's threads start in any order).
    if (a.cycle.found) {
      std::vector<int64_t> starts = a.cycle.starts_ns;
      const double half_ns = a.cycle.period.p50_ns / 2;
      for (const BusStats& b : a.buses) {
        if (!b.cycle.found) continue;
        for (int64_t s : b.cycle.starts_ns) {
          const std::size_t k = nearest_start(a.cycle.starts_ns, s);
          if (std::abs(static_cast<double>(s - a.cycle.starts_ns[k])) <= half_ns) starts[k] = std::min(starts[k], s);
        }
      }
      set_cycle_starts(a.cycle, order, std::move(starts));
    }
  }
  return a;
}

}  // namespace doppel::analyzer
