#pragma once
// doppel-replay --bus: the driver's recorded instruction bytes written again to a doppel's
// pseudo-terminal at the recorded pace, and what comes back compared with what the recording
// says came back, status by status and, for reads, register by register. What should match
// between two runs of the same robot: every PING answer (model number, firmware), the status
// error bytes, and reads of EEPROM registers and of RAM values the driver itself wrote (Goal
// Position, Torque Enable, ...). What may differ: values the physics produces (Present Position,
// Speed, Load, Voltage, Temperature, Moving, Realtime Tick, IMU and foot values), because the
// fresh world is not the recorded one. The comparison is pure logic (frame_statuses, read_ranges,
// compare_transaction); BusReplayer does the I/O. Not real-time code; a test and tool helper.

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "proto/recording.pb.h"
#include "replay/recording.h"

namespace doppel::replay {

// One status packet as it came over the line (either protocol).
struct StatusFrame {
  uint8_t protocol = 1;
  uint8_t id = 0;
  uint8_t error = 0;        // the status' error byte
  bool checksum_ok = true;
  std::string params;       // data after the error byte (Protocol 2.0: unstuffed)
  std::string bytes;        // wire bytes
};
// Every whole status packet in `bytes`, in order; bytes that are no packet are skipped and
// counted in `*unframed` (when given).
std::vector<StatusFrame> frame_statuses(std::string_view bytes, std::size_t* unframed = nullptr);

// A register range an instruction asks a device to return (READ, SYNC READ, BULK READ of either
// protocol; FAST reads are compared byte by byte only).
struct ReadRange {
  uint8_t id = 0;
  uint16_t address = 0;
  uint16_t length = 0;
};
// The instruction packet in `bytes` (a recorded BusTransaction.instruction) and the ranges it reads.
struct Instruction {
  bool framed = false;
  uint8_t protocol = 1;
  uint8_t id = 0;
  uint8_t code = 0;
  std::string name;  // PING, READ, WRITE, SYNC_WRITE, ... or "0xNN"
  std::vector<ReadRange> reads;
};
Instruction parse_instruction(std::string_view bytes);

// Register names and areas by device ID, from the recording's device list and Doppel's model
// registry (an unknown model: byte addresses only).
class RegisterNames {
 public:
  RegisterNames() = default;
  explicit RegisterNames(const recording::BusInfo& bus);
  struct Register {
    std::string name;   // e-Manual name, or "address N"
    uint16_t address = 0;
    uint8_t size = 1;
    bool eeprom = false;
    bool known = false;
  };
  // The register of device `id` containing `address`.
  Register at(uint8_t id, uint8_t protocol, uint16_t address) const;

 private:
  std::map<uint8_t, std::string> models_;  // id -> model name
};

// One register whose value differs between the recording and the replay.
struct RegisterDifference {
  uint8_t id = 0;
  std::string name;
  uint16_t address = 0;
  bool eeprom = false;
  int64_t recorded = 0, replayed = 0;  // little-endian value of the bytes read (unsigned)
};

enum class Verdict : uint8_t {
  kMatched,     // every status byte equal (or no status, as recorded)
  kValues,      // same devices, same error bytes, only RAM register values differ (physics)
  kDiffered,    // anything else differs: error byte, EEPROM register, length, a device answering or not
  kMissing,     // a status was recorded, none came back in time
  kUnexpected,  // no status was recorded, one came back
};
const char* verdict_name(Verdict verdict) noexcept;

struct TransactionResult {
  uint64_t sequence = 0;
  std::string instruction;  // name, e.g. "READ ID 3"
  Verdict verdict = Verdict::kMatched;
  std::string note;         // what differs, one sentence
  std::vector<RegisterDifference> differences;
  int64_t recorded_reply_ns = -1;  // written_ns - first_seen_ns of the recording; -1 no status
  int64_t replayed_reply_ns = -1;  // write() to the last status byte read; -1 none
  int64_t send_late_ns = 0;        // how much later than scheduled the instruction went out (timer jitter)
  int64_t schedule_slip_ns = 0;    // the schedule slipped by this before it (the previous answer came late)
};

// Compares the statuses that came back (`replayed`, the raw bytes read) with the recorded ones.
TransactionResult compare_transaction(const recording::BusTransaction& recorded, std::string_view replayed,
                                      const RegisterNames& names);

struct BusReplayOptions {
  double speed = 1.0;                  // recorded pace x speed (2: twice as fast)
  int64_t reply_timeout_ns = 100'000'000;  // beyond the recorded reply time: no status means missing
};

// Opens `link` (a doppel bus' pseudo-terminal) as a driver does: read/write, non-blocking, raw 8N1
// at `baud_bps` (termios2 BOTHER). Throws std::runtime_error naming the link and the reason.
int open_bus_port(const std::string& link, uint32_t baud_bps);

// An instruction that got no status in the recording still listens this long before the next
// one goes (when the recorded gap is longer), to see an answer where none was recorded.
inline constexpr int64_t kMinListenNs = 2'000'000;
// Later than its schedule by more than this (not timer jitter): the schedule slips, keeping the
// recorded gaps from there on rather than hurrying to catch up.
inline constexpr int64_t kSlipThresholdNs = 1'000'000;

// Replays `transactions` (one bus, in recording order) on `fd`, an open, raw pty of a doppel: each
// instruction at its recorded offset from the first (first_seen_ns) divided by the speed, after
// waiting for as many status packets as were recorded (up to the recorded reply time plus the
// timeout), as the driver did.
// Sets the line rate to each transaction's baud_bps (termios2 BOTHER) when it changes. Throws
// std::runtime_error when the port fails (write error, hang-up).
class BusReplayer {
 public:
  BusReplayer(int fd, RegisterNames names, BusReplayOptions options = {});
  // `progress(done, total)` after each transaction (may be empty).
  std::vector<TransactionResult> run(const std::vector<recording::BusTransaction>& transactions,
                                     const std::function<void(std::size_t, std::size_t)>& progress = {});

 private:
  int fd_;
  RegisterNames names_;
  BusReplayOptions options_;
  uint32_t baud_bps_ = 0;
};

struct BusReplaySummary {
  std::map<Verdict, uint64_t> verdicts;
  // Reply times (transactions with a status both times), ns.
  int64_t recorded_p50_ns = 0, recorded_p99_ns = 0, replayed_p50_ns = 0, replayed_p99_ns = 0;
  int64_t send_late_p99_ns = 0;
  int64_t schedule_slip_ns = 0;  // in all
  std::map<std::string, uint64_t> differing_registers;  // "ID 3 Present Position" -> transactions
};
BusReplaySummary summarize(const std::vector<TransactionResult>& results);
// A text report: one line per transaction that differed, was missing or unexpected (at most
// `max_lines`), three whose RAM values differ, then the summary. `every`: one line for every
// transaction instead, in order, matched ones included (with both reply times).
std::string format_report(const std::vector<TransactionResult>& results, const BusReplaySummary& summary,
                          std::size_t max_lines = 50, bool every = false);

// The transactions of robot `robot`, bus `bus` in a recording, in sequence order, and the bus'
// BusInfo from /doppel/run (none when the recording has no RunInfo for it).
struct RecordedBus {
  std::vector<recording::BusTransaction> transactions;
  std::optional<recording::BusInfo> info;
  uint64_t sequence_gaps = 0;  // transactions the recording lost (dropped by the recorder)
};
RecordedBus load_bus(const std::string& path, uint32_t robot, uint32_t bus);
// The (robot, bus) pairs that have transactions in a recording.
std::vector<std::pair<uint32_t, uint32_t>> recorded_buses(const std::string& path);

}  // namespace doppel::replay
