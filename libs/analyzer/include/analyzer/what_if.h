#pragma once
// "What if": a robot's recorded control cycles put through the bus' own wire and adapter models
// (bus::WireTiming, bus::AdapterLatency) with other settings: baud rate, Return Delay Time,
// firmware time, USB latency timer, adapter, or the devices spread over N buses. The answer is the
// cycle time the bus alone would allow, next to the recorded one. docs/analyzer.md lists the
// assumptions; in short: the driver sends each instruction as soon as it has the previous one's
// reply (and at once after an instruction without reply; driver=recorded adds the time it took in
// the recording), buses run in parallel and a cycle ends
// when the slowest is done, multi-device instructions are split per bus (never merged), and a
// recorded timeout costs what it cost in the recording. Allocates: not for real-time threads.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "analyzer/analysis.h"
#include "bus/adapter_profile.h"
#include "proto/recording.pb.h"

namespace doppel::analyzer {

// Settings that differ from the recording; unset ones stay as recorded (per transaction).
struct Scenario {
  std::optional<uint32_t> baud_bps;         // baud=BPS: every bus' line rate
  std::optional<uint32_t> return_delay_us;  // rdt=US: every device's Return Delay Time
  std::optional<int64_t> processing_ns;     // fw=US: device firmware time before the RDT
  std::optional<uint32_t> latency_ms;       // latency=MS: FTDI latency timer (0: no adapter delay)
  std::optional<bus::AdapterProfile> adapter;  // adapter=ftdi|usb2ax
  std::optional<uint32_t> buses;            // buses=N: the robot's devices spread over N buses
  bool driver_time = false;                 // driver=recorded: keep the driver's own time between a
                                            // reply and its next instruction (default: none)
};

// Parses "baud=3000000,rdt=0,latency=1,buses=4" (keys baud, rdt, fw, latency, adapter, buses,
// driver=recorded|0; ""
// and "recorded" are the recording's own settings). Throws std::invalid_argument with a sentence
// naming the bad part.
Scenario parse_scenario(const std::string& text);
// The canonical text of a scenario ("recorded" when nothing is changed).
std::string describe(const Scenario& scenario);

// The scenarios a report shows when none is asked for: the recording's own settings without and
// with the driver's own time, then the usual remedies that differ from the recording, each on top
// of the previous ones: latency timer 1 ms, RDT 0, 2 buses, 4 buses.
std::vector<Scenario> default_scenarios(const recording::RunInfo& run, const Analysis& analysis);

struct WhatIf {
  Scenario scenario;
  std::string label;        // describe(scenario)
  uint32_t buses = 0;       // buses the traffic ran on
  uint64_t cycles = 0;      // cycles simulated (the recorded ones, back to back)
  Distribution cycle;       // simulated cycle time, ns
  double rate_hz = 0.0;     // 1e9 / mean cycle time
  std::string note;         // why nothing was simulated ("" when cycles > 0)
};

// Simulates every recorded cycle of `analysis.cycle` (from one cycle start to the next, all buses
// of `analysis.robot`) under `scenario`, back to back from t = 0. `transactions` are the same the
// analysis was made from.
WhatIf what_if(const recording::RunInfo& run, std::span<const Transaction> transactions, const Analysis& analysis,
               const Scenario& scenario);
// The same on the messages as recorded (compacted first).
WhatIf what_if(const recording::RunInfo& run, std::span<const recording::BusTransaction> transactions,
               const Analysis& analysis, const Scenario& scenario);

}  // namespace doppel::analyzer
