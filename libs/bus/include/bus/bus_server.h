#pragma once
// Serves one Dynamixel bus on one PtyPort: reads the driver's bytes, frames Protocol 1.0 and 2.0
// instruction packets (both may share the bus, dynamixel::PacketFramer), lets the bus's devices answer (dynamixel::BusDevices), and writes their
// status bytes back at the times the wire and adapter models give. One thread runs it; it never
// allocates, locks or logs per packet, and it never waits for the simulation (DeviceSync hooks
// must not wait either). It does not own the devices or decide what they answer.
//
// Connection handling: when the client closes the port (or is killed, even mid-packet) the bytes
// it wrote are still served, a trailing partial packet is dropped, undelivered replies are
// discarded, and the next client starts on a clean line (see PtyPort).

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>

#include "bus/adapter_latency.h"
#include "bus/adapter_profile.h"
#include "bus/pty_port.h"
#include "bus/reply_schedule.h"
#include "bus/spin_budget.h"
#include "bus/traffic_tap.h"
#include "bus/wire_timing.h"
#include "concurrency/spsc_queue.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/packet_framer.h"
#include "dynamixel/usb2ax.h"

namespace doppel {
class Fnv1a;
}

namespace doppel::bus {

struct BusServerOptions {
  TimingMode timing_mode = TimingMode::kWire;                // kFast: answer at once
  int64_t processing_ns = WireTiming::kDefaultProcessingNs;  // device firmware time before RDT, ns
  uint32_t adapter_latency_ms = 0;   // USB adapter latency timer, ms (0 = none, FTDI default 16); wire mode only
  AdapterProfile adapter = AdapterProfile::kFtdi;  // kUsb2ax ignores adapter_latency_ms (it has no such timer)
  int64_t spin_ns = 50'000;          // sleep until this long before a due delivery, then busy-wait (0 = sleep only)
  SpinBudget* spin_budget = nullptr; // who may busy-wait at once; nullptr = SpinBudget::process()
  // While run() serves, a SCHED_OTHER bus thread asks the scheduler (Linux 6.12+, EEVDF custom slice)
  // for slices of this length (0 = the kernel's default; it allows 0.1..100 ms): a waking thread
  // whose slice is shorter than the running task's may preempt it at once instead of waiting until
  // that task has used up its slice (by default 0.75 ms, more with more CPUs), so the wake-up before
  // a due delivery comes in time while physics, the camera or another program holds the core.
  int64_t slice_ns = 100'000;
  int64_t late_threshold_ns = 100'000;  // a delivery written later than due + this counts as late
  int64_t idle_wait_ns = 10'000'000;    // longest single wait: bounds how soon run() notices stop
  bool record_traces = false;           // push one ReplyTrace per reply into traces()
  TrafficTap* tap = nullptr;            // when set, every byte, instruction and reply is reported there (record/)
  // Lockstep (docs/lockstep.md): time is read from here (simulation ns) instead of CLOCK_MONOTONIC,
  // and serve_lockstep() replaces run(). nullptr = the wall clock.
  const std::atomic<int64_t>* clock = nullptr;
  Fnv1a* hash = nullptr;                // when set, every byte in and out is folded in with its time and direction
};

// Delivery lateness (written - due) is counted in bins of kLatenessBinNs; the last bin also holds
// everything later. It is Doppel's own timing error, without the pty's transport time.
inline constexpr std::size_t kLatenessBins = 101;
inline constexpr int64_t kLatenessBinNs = 10'000;

// Counters of one bus (monotonic since construction unless noted). Read from any thread.
struct BusDiagnostics {
  uint64_t packets = 0;          // instruction packets framed (good or bad checksum)
  uint64_t bad_checksums = 0;    // of those, with a wrong checksum
  uint64_t bytes_in = 0;         // bytes read from the client
  uint64_t bytes_out = 0;        // status bytes written to the client
  uint64_t dropped_bytes = 0;    // bytes skipped while hunting for a packet header
  uint64_t timeouts = 0;         // partial packets dropped by the inter-byte timeout (P1 100 ms, P2 1.5 ms)
  uint64_t connects = 0;         // client sessions started
  uint64_t reconnects = 0;       // client sessions ended (port closed or client killed), line cleaned
  uint64_t replies = 0;          // instructions that got at least one status scheduled
  uint64_t dropped_replies = 0;  // replies dropped because the schedule was full (client not reading)
  uint64_t merged_segments = 0;  // deliveries merged into a later one because the schedule was full
  uint64_t discarded_bytes = 0;  // reply bytes dropped because their client had gone
  uint64_t late_deliveries = 0;  // deliveries written more than late_threshold_ns after due
  int64_t max_lateness_ns = 0;   // worst (written - due) seen, ns
  uint32_t line_baud_bps = 0;    // line rate at the last read, bit/s
  bool connected = false;        // a client has the port open
  std::array<uint64_t, kLatenessBins> lateness_bins{};  // deliveries per lateness bin (see kLatenessBinNs)
};

// The q-quantile (0 < q <= 1) of the delivery lateness, ns: the upper edge of the bin that holds
// it (so never below the true value); 0 when nothing was delivered. rt-safe.
int64_t lateness_quantile_ns(const BusDiagnostics& diagnostics, double q) noexcept;

// Called by the bus thread around every dispatched packet, e.g. to copy the latest simulation
// snapshot into the control tables and to publish the commands written by the packet. Both run on
// the bus thread and must not block, allocate or wait for another thread.
class DeviceSync {
 public:
  virtual ~DeviceSync() = default;
  virtual void before_dispatch() noexcept = 0;
  virtual void after_dispatch() noexcept = 0;
  // Called about every BusServer::kTickNs also without traffic (and without a client), so that
  // devices see time pass (Protocol 2.0 Bus Watchdog). Same rules as above.
  virtual void on_tick() noexcept {}
  // Called with the statuses the devices gave for one packet, before they are timed and
  // scheduled; may answer others (faults/: late, lost, corrupted or stray statuses) that stay
  // valid until the next call. Same rules as above.
  virtual std::span<const dynamixel::OutgoingStatus> impair(const dynamixel::InstructionPacket& packet,
                                                            std::span<const dynamixel::OutgoingStatus> statuses) noexcept {
    (void)packet;
    return statuses;
  }
};

class BusServer {
 public:
  static constexpr int64_t kInterByteTimeoutNs = 100'000'000;    // Protocol 1.0 (reference §1.1)
  static constexpr int64_t kP2InterByteTimeoutNs = 1'500'000;    // Protocol 2.0 (reference §2.1)
  static constexpr int64_t kTickNs = 10'000'000;                 // DeviceSync::on_tick period
  static constexpr std::size_t kTraceCapacity = 1024;
  using TraceQueue = concurrency::SpscQueue<ReplyTrace, kTraceCapacity>;

  // `port`, `devices` and `sync` (optional) must outlive the server; devices are added before run().
  // Throws std::invalid_argument for negative times or an adapter latency above 255 ms. Setup only.
  BusServer(PtyPort& port, dynamixel::BusDevices& devices, const BusServerOptions& options = {},
            DeviceSync* sync = nullptr);

  BusServer(const BusServer&) = delete;
  BusServer& operator=(const BusServer&) = delete;

  // Serves until `stop` becomes true (checked at least every idle_wait_ns). Sets the calling
  // thread's timer slack to 1 ns and, when it runs SCHED_OTHER, its slice to options.slice_ns
  // while it runs. Call from one thread only. rt-safe after setup.
  void run(const std::atomic<bool>& stop) noexcept;

  // One iteration: waits at most `max_wait_ns` for input, a client or a due delivery, then reads,
  // dispatches and writes what is due. For callers with their own loop. rt-safe.
  void run_once(int64_t max_wait_ns) noexcept;

  // Sets options.clock and options.hash (see there) before the server is first served. Setup.
  void use_lockstep_clock(const std::atomic<int64_t>* clock, Fnv1a* hash) noexcept {
    options_.clock = clock;
    options_.hash = hash;
  }
  // Lockstep: one pass at the time of options.clock, called by the simulation thread instead of
  // run(). Accepts a client, reads until `input_total` bytes have been read since construction
  // (what the controller wrote before it waited; at most `settle_ns` of wall time for the pty to
  // hand them over), dispatches them and writes the bytes that are due. With nothing to read it
  // asks the pty only when `check_line` (a hang-up, a client that writes without the shim). rt-safe.
  void serve_lockstep(uint64_t input_total, int64_t settle_ns, bool check_line) noexcept;
  // Status bytes written to the client so far (BusDiagnostics::bytes_out, without the copy). rt-safe.
  uint64_t bytes_out() const noexcept { return counters_.bytes_out.load(std::memory_order_relaxed); }
  // When the next reply bytes are due; INT64_MAX when none are (or the client's queue is full). rt-safe.
  int64_t next_due_ns() const noexcept;

  // Snapshot of the counters. Any thread, lock-free.
  BusDiagnostics diagnostics() const noexcept;

  // Model predictions and actual write times, one per reply when options.record_traces is set.
  // Exactly one consumer thread may pop; when nobody does, new traces are dropped (and counted).
  TraceQueue& traces() noexcept { return traces_; }

  const BusServerOptions& options() const noexcept { return options_; }

  // Sets the USB adapter's latency timer (ms, 0 = no adapter) as a driver does through the FTDI
  // latency_timer file; the bus thread applies it before the next reply (fast timing models no
  // adapter, and a USB2AX has no such timer: the setting is kept, not applied). False above 255 ms. Any thread, lock-free.
  bool set_adapter_latency_ms(uint32_t latency_ms) noexcept;
  // The latency timer set (options or set_adapter_latency_ms). Any thread, lock-free.
  uint32_t adapter_latency_ms() const noexcept;

 private:
  struct Counters {
    std::atomic<uint64_t> packets{0}, bad_checksums{0}, bytes_in{0}, bytes_out{0}, dropped_bytes{0},
        timeouts{0}, connects{0}, reconnects{0}, replies{0}, dropped_replies{0}, merged_segments{0},
        discarded_bytes{0}, late_deliveries{0};
    std::atomic<int64_t> max_lateness_ns{0};
    std::atomic<uint32_t> line_baud_bps{0};
    std::atomic<bool> connected{false};
    std::array<std::atomic<uint64_t>, kLatenessBins> lateness_bins{};
  };

  // Reads and processes what the pty holds, until it holds nothing or `until_total` bytes were read
  // since construction (lockstep knows how many the controller wrote).
  void read_input(uint64_t until_total = UINT64_MAX) noexcept;
  int64_t now() const noexcept;  // options_.clock or CLOCK_MONOTONIC
  void hash_bytes(uint8_t direction, int64_t t_ns, const uint8_t* bytes, std::size_t n) noexcept;
  void process(const uint8_t* bytes, std::size_t n, int64_t seen_ns, uint32_t baud_bps) noexcept;
  void dispatch(const dynamixel::InstructionPacket& packet, int64_t instruction_end_ns, int64_t seen_ns,
                uint32_t baud_bps, uint64_t stream_end) noexcept;
  // Reports to options_.tap, if any. rt-safe.
  void tap(TapEventKind kind, int64_t t0_ns, int64_t t1_ns = 0, std::span<const uint8_t> payload = {},
           uint32_t value = 0) noexcept;
  void write_due() noexcept;
  void account_delivery(const ReplySchedule::Progress& progress, int64_t written_ns) noexcept;
  void await_due(int64_t due_ns) noexcept;
  void on_connect() noexcept;
  void on_hang_up() noexcept;
  // kUsb2ax: lets the adapter see `packet` first; true when it consumed it (bus_server_usb2ax.cpp).
  bool usb2ax_intercepts(const dynamixel::InstructionPacket& packet, int64_t seen_ns, uint32_t baud_bps) noexcept;
  void usb2ax_sync_read(int64_t start_ns, uint32_t baud_bps, ReplyTrace trace) noexcept;
  void schedule_adapter_status(const dynamixel::StatusPacket& status, int64_t due_ns, ReplyTrace trace) noexcept;

  PtyPort& port_;
  dynamixel::BusDevices& devices_;
  DeviceSync* sync_;
  BusServerOptions options_;
  SpinBudget& spin_budget_;
  WireTiming timing_;
  AdapterLatency adapter_;
  void tick() noexcept;

  dynamixel::Usb2axFirmware usb2ax_;
  int64_t host_delay_ns_ = 0;   // kUsb2ax in wire mode: its send timeout before bytes reach the host
  dynamixel::PacketFramer parser_;
  ReplySchedule schedule_;
  TraceQueue traces_;
  Counters counters_;
  int64_t last_input_ns_ = 0;   // when the previous input chunk had crossed the wire (fast: was read)
  int64_t last_tick_ns_ = 0;    // last DeviceSync::on_tick
  bool write_blocked_ = false;  // the client's queue was full at the last write
  uint8_t hashed_direction_ = 0;   // options_.hash: direction and time of the bytes folded in last
  int64_t hashed_ns_ = -1;
  uint64_t stream_offset_ = 0;  // driver bytes read so far (the tap's stream positions)
  uint64_t sequence_ = 0;       // transaction (framed instruction) being served
  uint64_t next_sequence_ = 0;  // the next framed instruction's, per bus from 0
  std::atomic<uint32_t> requested_latency_ms_{0};  // set_adapter_latency_ms, applied by the bus thread
};

}  // namespace doppel::bus
