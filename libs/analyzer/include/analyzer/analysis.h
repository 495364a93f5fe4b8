#pragma once
// The bus analyzer's findings for one robot's recorded traffic (doppel --record, libs/proto/recording.proto):
// the driver's control cycle found from its own traffic, where the time of each kind of
// transaction goes, how busy each wire is, and the timeouts and retries seen. docs/analyzer.md says
// what every number means. Pure computation on messages in memory; reading files is
// recording_reader.h, the "what if" is what_if.h. Allocates: not for real-time threads.

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "analyzer/transaction.h"
#include "proto/recording.pb.h"

namespace doppel::analyzer {

// Summary of a sample of durations, ns. Percentiles are nearest-rank (the p-th value of the sorted
// sample, never interpolated); everything is 0 for an empty sample.
struct Distribution {
  uint64_t count = 0;     // values
  double mean_ns = 0.0;
  double stddev_ns = 0.0; // population standard deviation
  double min_ns = 0.0;
  double p50_ns = 0.0;
  double p99_ns = 0.0;
  double max_ns = 0.0;
};
Distribution summarize(std::vector<double> values_ns);

// The repeating pattern of a driver's traffic. The cycle starts when the driver sends the
// instruction that opens each repetition (the opener); see find_cycle.
struct CycleStats {
  bool found = false;             // at least 3 repetitions of one request were seen
  std::string opener_kind;        // e.g. "P2 SYNC WRITE"
  std::string opener_signature;   // analyzer::signature of the opener, with its bus in front
  uint32_t opener_bus = 0;        // bus of the opener
  uint64_t cycles = 0;            // cycle starts seen (periods = cycles - 1)
  uint64_t startup_transactions = 0;  // transactions before the first cycle start (pings, table reads)
  int64_t first_start_ns = 0;     // first_seen_ns of the first opener
  int64_t last_start_ns = 0;      // and of the last
  Distribution period;            // between consecutive cycle starts
  Distribution busy;              // cycle start until the last transaction before the next start is done
  double rate_hz = 0.0;           // 1e9 / mean period
  std::vector<int64_t> starts_ns; // every cycle start (for plots and the what-if)
};

// The time split of one kind of transaction (protocol + instruction), over its transactions that
// did not time out (a timeout's cost is its wait, TimeoutEvent). The parts add up: host write +
// return delay + status wire + status gaps + adapter + lateness = total (for each transaction
// whose statuses were delivered; means add up too when every one of the kind was).
struct KindStats {
  std::string kind;             // "P2 SYNC READ"
  uint64_t count = 0;           // transactions
  uint64_t answered = 0;        // of those with at least one status
  uint64_t statuses = 0;        // status packets
  uint64_t timeouts = 0;        // an expected status missing (see TimeoutEvent)
  uint64_t retries = 0;         // the same bytes sent again right after a timeout
  uint64_t bad_checksums = 0;   // framed with a wrong checksum / CRC (no device answers those)
  Distribution host_write;      // instruction_end - first_seen: the driver's write until the last byte crossed
  Distribution return_delay;    // first status start - instruction end: firmware time + Return Delay Time
  Distribution status_wire;     // bytes of all statuses on the wire
  Distribution status_gaps;     // between the statuses of one reply (each later device's firmware time + RDT)
  Distribution adapter;         // due - last status end: the USB adapter holding the bytes
  Distribution lateness;        // written - due: Doppel's own timing error (not the bus' cost)
  Distribution total;           // written (or due) - first_seen: what the driver waited
};

// An instruction that expected an answer and did not get all of it.
struct TimeoutEvent {
  uint32_t bus = 0;
  uint64_t sequence = 0;
  int64_t time_ns = 0;              // first_seen_ns of the instruction
  std::string kind;
  std::vector<uint8_t> missing_ids; // devices that did not answer
  int64_t wait_ns = -1;             // until the driver sent its next instruction on this bus (-1: none followed)
  bool retried = false;             // that next instruction was the same bytes
};

struct BusStats {
  uint32_t robot = 0;
  uint32_t bus = 0;
  std::string link;                 // from BusInfo ("" when the run info does not list the bus)
  uint32_t baud_bps = 0;            // line rate of the last transaction
  uint64_t transactions = 0;
  uint64_t missing_transactions = 0;  // sequence gaps: dropped by the recorder
  uint64_t dropped_replies = 0;     // the driver was not reading when a status was due
  int64_t span_ns = 0;              // first instruction start to last byte on the wire
  int64_t busy_ns = 0;              // instruction and status bytes on the wire
  double utilisation = 0.0;         // busy / span
  double loop_utilisation = 0.0;    // the same from the first to the last cycle start of this bus
  uint64_t timeouts = 0;
  uint64_t retries = 0;
  Distribution timeout_wait;        // TimeoutEvent::wait_ns
  CycleStats cycle;                 // this bus' own cycle
};

struct Analysis {
  uint32_t robot = 0;
  std::string robot_name;
  std::string timing_mode;          // RunInfo: "wire" or "fast" (fast: no wire times, see docs)
  uint64_t transactions = 0;
  std::vector<BusStats> buses;      // by bus index
  CycleStats cycle;                 // all buses together: the opener of one bus, each cycle
                                    // starting when the first bus starts it (that bus' opener)
  std::vector<KindStats> kinds;     // by count, most frequent first
  std::vector<TimeoutEvent> timeouts;  // in time order
  uint64_t retries = 0;
};

// The repeating request that opens each cycle, among `transactions` (time order): of the
// signatures seen at least 3 times and at least 1/8 as often as the most frequent one, those whose
// median idle time before them (since the previous transaction was done) is at least half the
// largest such median; of these the least frequent (the longest repetition), then the earliest.
// A driver that sleeps until its next tick has its opener right after the sleep; one that runs
// flat out gets its coarsest repeating request. Start-up traffic (pings, table reads) is seen only
// once or twice and never opens a cycle. Idle times are per bus (a driver may run a thread per
// bus). `with_bus` puts the bus into the signature (several buses).
CycleStats find_cycle(std::span<const Transaction* const> transactions, bool with_bus);

// Sets the cycle starts (sorted here) and everything computed from them: counts, period, busy
// time, start-up transactions. `transactions` in time order.
void set_cycle_starts(CycleStats& cycle, std::span<const Transaction* const> transactions, std::vector<int64_t> starts_ns);

// Index of the start nearest to t_ns (starts sorted, not empty).
std::size_t nearest_start(std::span<const int64_t> starts_ns, int64_t t_ns);

// Analyses the transactions of one robot (any order, any of its buses). `run` supplies the bus
// links, device lists and timing mode (an empty RunInfo is fine: those fields stay empty).
Analysis analyze(const recording::RunInfo& run, std::span<const Transaction> transactions, uint32_t robot);
// The same on the messages as recorded (compacted first).
Analysis analyze(const recording::RunInfo& run, std::span<const recording::BusTransaction> transactions,
                 uint32_t robot);

// Statuses the transaction should have had, by device ID; `answers_writes(id)` says whether that
// device answers non-read instructions (its Status Return Level, as learned from the recording).
std::vector<uint8_t> expected_status_ids(const Transaction& transaction,
                                         const std::function<bool(uint8_t)>& answers_writes);

}  // namespace doppel::analyzer
