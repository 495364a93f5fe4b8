#include "analyzer/what_if.h"

#include <algorithm>
#include <charconv>
#include <map>
#include <set>
#include <stdexcept>

#include "analyzer/instruction.h"
#include "bus/adapter_latency.h"
#include "bus/wire_timing.h"
#include "dynamixel/packet.h"
#include "dynamixel/usb2ax.h"

namespace doppel::analyzer {

namespace ins = dynamixel::instruction;


namespace {

std::span<const uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

template <class T>
T parse_number(const std::string& key, const std::string& value, T min, T max) {
  T out{};
  const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), out);
  if (error != std::errc() || end != value.data() + value.size() || out < min || out > max) {
    throw std::invalid_argument("what-if '" + key + "=" + value + "': not a number in [" + std::to_string(min) + ", " +
                                std::to_string(max) + "]");
  }
  return out;
}

// One status of a simulated reply.
struct SimStatus {
  std::size_t bytes = 0;
  uint32_t return_delay_us = 0;
  bool after_previous = false;
  bool continues_previous = false;
  int64_t extra_delay_ns = 0;
};

// One instruction on one of the scenario's buses.
struct SimTransaction {
  std::size_t bus = 0;
  std::size_t instruction_bytes = 0;
  uint32_t baud_bps = 0;
  uint32_t latency_ms = 0;
  bool usb2ax = false;
  std::vector<SimStatus> statuses;
  int64_t timeout_wait_ns = -1;  // the recorded wait after a timeout (-1: none)
  int64_t driver_ns = 0;         // the driver's own time before it sent this (driver=recorded)
  // USB2AX SYNC READ: the adapter reads every servo itself (READ of 8 B, answer of 6 + N B).
  std::vector<uint32_t> usb2ax_servo_rdt_us;
  uint16_t usb2ax_read_bytes = 0;
};

using DeviceKey = std::pair<uint32_t, uint8_t>;  // recorded bus, ID

}  // namespace

Scenario parse_scenario(const std::string& text) {
  Scenario s;
  if (text.empty() || text == "recorded") return s;
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string part = text.substr(at, comma - at);
    const std::size_t equals = part.find('=');
    if (equals == std::string::npos) throw std::invalid_argument("what-if '" + part + "': expected key=value");
    const std::string key = part.substr(0, equals);
    const std::string value = part.substr(equals + 1);
    if (key == "baud") {
      s.baud_bps = parse_number<uint32_t>(key, value, 1200, 10'500'000);
    } else if (key == "rdt") {
      s.return_delay_us = parse_number<uint32_t>(key, value, 0, 508);
    } else if (key == "fw") {
      s.processing_ns = parse_number<int64_t>(key, value, 0, 100'000) * 1000;
    } else if (key == "latency") {
      s.latency_ms = parse_number<uint32_t>(key, value, 0, bus::AdapterLatency::kMaxLatencyMs);
    } else if (key == "buses") {
      s.buses = parse_number<uint32_t>(key, value, 1, 64);
    } else if (key == "driver") {
      if (value != "recorded" && value != "0") {
        throw std::invalid_argument("what-if 'driver=" + value + "': expected recorded or 0");
      }
      s.driver_time = value == "recorded";
    } else if (key == "adapter") {
      if (value == "ftdi") {
        s.adapter = bus::AdapterProfile::kFtdi;
      } else if (value == "usb2ax") {
        s.adapter = bus::AdapterProfile::kUsb2ax;
      } else {
        throw std::invalid_argument("what-if 'adapter=" + value + "': expected ftdi or usb2ax");
      }
    } else {
      throw std::invalid_argument("what-if '" + part + "': unknown key '" + key +
                                  "' (known: baud, rdt, fw, latency, adapter, buses, driver)");
    }
    at = comma + 1;
  }
  return s;
}

std::string describe(const Scenario& s) {
  std::string out;
  auto add = [&](const std::string& part) { out += (out.empty() ? "" : ",") + part; };
  if (s.baud_bps) add("baud=" + std::to_string(*s.baud_bps));
  if (s.return_delay_us) add("rdt=" + std::to_string(*s.return_delay_us));
  if (s.processing_ns) add("fw=" + std::to_string(*s.processing_ns / 1000));
  if (s.latency_ms) add("latency=" + std::to_string(*s.latency_ms));
  if (s.adapter) add(std::string("adapter=") + (*s.adapter == bus::AdapterProfile::kUsb2ax ? "usb2ax" : "ftdi"));
  if (s.buses) add("buses=" + std::to_string(*s.buses));
  if (s.driver_time) add("driver=recorded");
  return out.empty() ? "recorded" : out;
}

std::vector<Scenario> default_scenarios(const recording::RunInfo& run, const Analysis& analysis) {
  std::vector<Scenario> out{Scenario{}};
  Scenario driver;
  driver.driver_time = true;
  out.push_back(driver);
  bool slow_timer = false;
  bool rdt = false;
  std::size_t devices = 0;
  for (const auto& b : run.buses()) {
    if (b.robot() != analysis.robot) continue;
    if (b.adapter_latency_ms() > 1 && b.adapter() != "usb2ax") slow_timer = true;
    for (const auto& d : b.devices()) {
      ++devices;
      if (d.return_delay_us() > 0) rdt = true;
    }
  }
  // Each remedy on top of the previous ones.
  Scenario cumulative;
  if (slow_timer) {
    cumulative.latency_ms = 1;
    out.push_back(cumulative);
  }
  if (rdt) {
    cumulative.return_delay_us = 0;
    out.push_back(cumulative);
  }
  const std::size_t buses = std::max<std::size_t>(1, analysis.buses.size());
  for (uint32_t n : {2u, 4u}) {
    if (n > buses && (devices == 0 || devices >= n)) {
      cumulative.buses = n;
      out.push_back(cumulative);
    }
  }
  return out;
}

WhatIf what_if(const recording::RunInfo& run, std::span<const recording::BusTransaction> messages,
               const Analysis& analysis, const Scenario& scenario) {
  const std::vector<Transaction> transactions = compact(messages);
  return what_if(run, transactions, analysis, scenario);
}

WhatIf what_if(const recording::RunInfo& run, std::span<const Transaction> all, const Analysis& analysis,
               const Scenario& scenario) {
  WhatIf result;
  result.scenario = scenario;
  result.label = describe(scenario);
  if (!analysis.cycle.found || analysis.cycle.starts_ns.size() < 2) {
    result.note = "no control cycle found";
    return result;
  }

  std::vector<const Transaction*> order;
  for (const Transaction& t : all) {
    if (t.robot == analysis.robot) order.push_back(&t);
  }
  std::stable_sort(order.begin(), order.end(), [](const Transaction* x, const Transaction* y) {
    if (x->first_seen_ns != y->first_seen_ns) return x->first_seen_ns < y->first_seen_ns;
    if (x->bus != y->bus) return x->bus < y->bus;
    return x->sequence < y->sequence;
  });

  // The robot's devices (run info and traffic), their Return Delay Times, the buses and their firmware time.
  std::map<DeviceKey, uint32_t> rdt_us;
  std::set<uint32_t> recorded_buses;
  std::map<uint32_t, int64_t> processing_ns;
  for (const auto& b : run.buses()) {
    if (b.robot() != analysis.robot) continue;
    recorded_buses.insert(b.bus());
    processing_ns[b.bus()] = b.processing_ns();
    for (const auto& d : b.devices()) rdt_us[{b.bus(), static_cast<uint8_t>(d.id())}] = d.return_delay_us();
  }
  for (const Transaction* t : order) {
    recorded_buses.insert(t->bus);
    for (const auto& s : t->statuses) {
      if (s.id < dynamixel::kBroadcastId - 1) rdt_us.try_emplace({t->bus, static_cast<uint8_t>(s.id)}, s.return_delay_us);
    }
  }
  auto recorded_processing = [&](uint32_t bus) {
    const auto it = processing_ns.find(bus);
    return it == processing_ns.end() ? bus::WireTiming::kDefaultProcessingNs : it->second;
  };
  int64_t bus_processing = 0;
  for (uint32_t b : recorded_buses) bus_processing = std::max(bus_processing, recorded_processing(b));
  if (scenario.processing_ns) bus_processing = *scenario.processing_ns;

  // Where every device goes: its recorded bus, or the N buses in contiguous, balanced groups.
  std::map<uint32_t, std::size_t> bus_slot;
  for (uint32_t b : recorded_buses) bus_slot.emplace(b, bus_slot.size());
  const std::size_t buses = scenario.buses ? *scenario.buses : std::max<std::size_t>(1, bus_slot.size());
  result.buses = static_cast<uint32_t>(buses);
  std::map<DeviceKey, std::size_t> placement;
  {
    std::size_t k = 0;
    for (const auto& [key, delay] : rdt_us) {
      placement[key] = scenario.buses ? k * buses / rdt_us.size() : bus_slot[key.first];
      ++k;
    }
  }
  auto place = [&](uint32_t bus, uint8_t id) {
    const auto it = placement.find({bus, id});
    return it != placement.end() ? it->second : bus_slot[bus] % buses;
  };

  std::map<std::pair<uint32_t, uint64_t>, int64_t> timeout_wait;
  for (const TimeoutEvent& e : analysis.timeouts) {
    if (e.wait_ns >= 0) timeout_wait[{e.bus, e.sequence}] = e.wait_ns;
  }

  // One recorded transaction as the scenario's buses see it (one entry per bus it reaches).
  auto convert = [&](const Transaction& t, int64_t driver_ns, std::vector<SimTransaction>& out) {
    const Instruction in = decode_instruction(t.protocol, bytes_of(t.instruction));
    SimTransaction base;
    base.driver_ns = scenario.driver_time ? driver_ns : 0;
    base.baud_bps = scenario.baud_bps ? *scenario.baud_bps : t.baud_bps;
    base.usb2ax = scenario.adapter ? *scenario.adapter == bus::AdapterProfile::kUsb2ax : t.usb2ax;
    base.latency_ms = base.usb2ax ? 0 : (scenario.latency_ms ? *scenario.latency_ms : t.adapter_latency_ms);
    const auto wait = timeout_wait.find({t.bus, t.sequence});
    if (wait != timeout_wait.end()) base.timeout_wait_ns = wait->second;
    const bool fast = in.framed && is_fast_read(in.protocol, in.code);
    const bool chained = in.framed && (is_multi_device(in.protocol, in.code) ||
                                      (in.protocol == 2 && in.code == ins::kPing && in.id == dynamixel::kBroadcastId));
    const int64_t recorded_fw = recorded_processing(t.bus);

    // The recorded statuses with what placed them, before any splitting.
    struct Recorded {
      uint8_t id;
      SimStatus status;
    };
    std::vector<Recorded> statuses;
    int64_t previous_end = t.instruction_end_ns;
    for (std::size_t i = 0; i < t.statuses.size(); ++i) {
      const auto& s = t.statuses[i];
      SimStatus sim;
      sim.bytes = s.bytes;
      sim.return_delay_us = scenario.return_delay_us ? *scenario.return_delay_us : s.return_delay_us;
      sim.after_previous = chained && i > 0;
      sim.continues_previous = fast && i > 0;
      if (!sim.continues_previous) {
        // Whatever the model added beyond firmware time and RDT (P2 broadcast PING slots) stays.
        const int64_t origin = sim.after_previous ? previous_end : t.instruction_end_ns;
        sim.extra_delay_ns = std::max<int64_t>(0, s.start_ns - origin - recorded_fw - int64_t{s.return_delay_us} * 1000);
      }
      previous_end = s.end_ns;
      statuses.push_back({static_cast<uint8_t>(s.id), sim});
    }

    const bool usb2ax_sync_read = in.framed && in.protocol == 1 && in.code == kUsb2axSyncRead;
    const bool split = scenario.buses && in.framed && is_multi_device(in.protocol, in.code);
    const bool broadcast = in.framed && in.id == dynamixel::kBroadcastId && !is_multi_device(in.protocol, in.code);
    std::vector<std::size_t> targets;
    if (split || broadcast) {
      for (std::size_t b = 0; b < buses; ++b) targets.push_back(b);
    } else {
      targets.push_back(in.framed ? place(t.bus, in.id) : bus_slot[t.bus] % buses);
    }
    for (std::size_t b : targets) {
      SimTransaction sim = base;
      sim.bus = b;
      auto on_bus = [&](uint8_t id) { return place(t.bus, id) == b; };
      if (split) {
        sim.instruction_bytes = encode_subset(in, on_bus).size();
        if (sim.instruction_bytes == 0) continue;
      } else {
        sim.instruction_bytes = t.instruction.size();
      }
      if (usb2ax_sync_read) {
        for (const Addressed& a : addressed_devices(in)) {
          if (split && !on_bus(a.id)) continue;
          const auto it = rdt_us.find({t.bus, a.id});
          sim.usb2ax_servo_rdt_us.push_back(scenario.return_delay_us ? *scenario.return_delay_us
                                                                     : (it == rdt_us.end() ? 0 : it->second));
          sim.usb2ax_read_bytes = a.read_bytes;
        }
      } else {
        const bool keep_all = !scenario.buses;
        for (std::size_t i = 0; i < statuses.size(); ++i) {
          if (!keep_all && !on_bus(statuses[i].id)) continue;
          SimStatus s = statuses[i].status;
          if (fast) {
            // The combined status' header goes with the first block on each bus.
            const bool first_here = sim.statuses.empty();
            if (i == 0 && !first_here) s.bytes -= std::min(s.bytes, kFastStatusHeaderBytes);
            if (i != 0 && first_here) s.bytes += kFastStatusHeaderBytes;
            s.continues_previous = !first_here;
            s.after_previous = !first_here;
          } else if (chained) {
            s.after_previous = !sim.statuses.empty();
          }
          sim.statuses.push_back(s);
        }
      }
      out.push_back(std::move(sim));
    }
  };

  std::vector<bus::WireTiming> wires;
  std::vector<bus::AdapterLatency> adapters(buses);
  for (std::size_t b = 0; b < buses; ++b) wires.emplace_back(bus::TimingMode::kWire, bus_processing);
  const int64_t usb2ax_host_delay_ns = dynamixel::Usb2axFirmware().send_timeout_ns();

  // Which recorded cycle each transaction belongs to. With several buses a bus that has its own
  // cycle is cut at its own cycle starts, each matched to the nearest combined one: a driver's
  // threads start a cycle in any order.
  const auto& starts = analysis.cycle.starts_ns;
  std::vector<std::vector<const Transaction*>> by_cycle(starts.size() - 1);
  std::map<uint32_t, const std::vector<int64_t>*> bus_starts;
  if (analysis.buses.size() > 1) {
    for (const BusStats& b : analysis.buses) {
      if (b.cycle.found) bus_starts[b.bus] = &b.cycle.starts_ns;
    }
  }
  const double half_period_ns = analysis.cycle.period.p50_ns / 2;
  for (const Transaction* t : order) {
    std::size_t k = 0;
    const auto own = bus_starts.find(t->bus);
    if (own != bus_starts.end()) {
      const std::vector<int64_t>& bus = *own->second;
      const auto after = std::upper_bound(bus.begin(), bus.end(), t->first_seen_ns);
      if (after == bus.begin() || after == bus.end()) continue;  // start-up, or after the bus' last cycle start
      const int64_t window_ns = *(after - 1);
      k = nearest_start(starts, window_ns);
      if (std::abs(static_cast<double>(window_ns - starts[k])) > half_period_ns) continue;
    } else {
      const auto after = std::upper_bound(starts.begin(), starts.end(), t->first_seen_ns);
      if (after == starts.begin()) continue;
      k = static_cast<std::size_t>(after - starts.begin()) - 1;
    }
    if (k + 1 < starts.size()) by_cycle[k].push_back(t);
  }

  std::vector<double> cycle_ns;
  int64_t now = 0;
  std::vector<SimTransaction> cycle;
  for (std::size_t k = 0; k + 1 < starts.size(); ++k) {
    cycle.clear();
    // The driver's own time: from having the previous transaction of the bus (its reply, or its
    // write returning) to writing this one; none after a timeout (the recorded wait has it).
    std::map<uint32_t, int64_t> had_previous;
    for (const Transaction* recorded : by_cycle[k]) {
      const Transaction& t = *recorded;
      const auto previous = had_previous.find(t.bus);
      const int64_t driver_ns = previous == had_previous.end() ? 0 : std::max<int64_t>(0, t.first_seen_ns - previous->second);
      convert(t, driver_ns, cycle);
      had_previous[t.bus] = timeout_wait.count({t.bus, t.sequence}) != 0 ? INT64_MAX : std::max(t.seen_ns, t.written_ns);
    }
    std::vector<int64_t> ready(buses, now);  // the driver can write the next instruction on the bus
    std::vector<int64_t> done(buses, now);
    for (const SimTransaction& sim : cycle) {
      bus::WireTiming& wire = wires[sim.bus];
      bus::AdapterLatency& adapter = adapters[sim.bus];
      ready[sim.bus] += sim.driver_ns;
      const bus::WireSpan span = wire.host_bytes(ready[sim.bus], sim.instruction_bytes, sim.baud_bps);
      int64_t end = span.end_ns;
      if (!sim.usb2ax_servo_rdt_us.empty()) {
        // The adapter sends each servo a READ and waits for its answer, then hands its status over.
        int64_t t = span.end_ns;
        for (uint32_t delay_us : sim.usb2ax_servo_rdt_us) {
          const bus::WireSpan read = wire.host_bytes(t, dynamixel::Usb2axFirmware::kServoReadBytes, sim.baud_bps);
          wire.begin_reply(read.end_ns);
          t = wire.status(std::size_t{6} + sim.usb2ax_read_bytes, delay_us, false, sim.baud_bps).end_ns;
        }
        end = t + usb2ax_host_delay_ns;
        ready[sim.bus] = end;
      } else if (!sim.statuses.empty()) {
        wire.begin_reply(span.end_ns);
        adapter.set_latency_ms(sim.latency_ms);
        adapter.begin_reply();
        int64_t due = span.end_ns;
        auto emit = [&](const bus::Delivery& d) { due = std::max(due, d.due_ns); };
        for (const SimStatus& s : sim.statuses) {
          const bus::WireSpan status = wire.status(s.bytes, s.return_delay_us, s.after_previous, sim.baud_bps,
                                                   s.extra_delay_ns, s.continues_previous);
          adapter.add_status(status, s.bytes, emit);
        }
        adapter.end_reply(emit);
        if (sim.usb2ax) due += usb2ax_host_delay_ns;
        end = due;
        ready[sim.bus] = due;
      }
      if (sim.timeout_wait_ns >= 0) {
        end += sim.timeout_wait_ns;
        ready[sim.bus] = end;
      }
      done[sim.bus] = std::max(done[sim.bus], end);
    }
    const int64_t cycle_end = *std::max_element(done.begin(), done.end());
    cycle_ns.push_back(static_cast<double>(cycle_end - now));
    now = cycle_end;
  }
  result.cycles = cycle_ns.size();
  result.cycle = summarize(std::move(cycle_ns));
  result.rate_hz = result.cycle.mean_ns > 0 ? 1e9 / result.cycle.mean_ns : 0.0;
  return result;
}

}  // namespace doppel::analyzer
