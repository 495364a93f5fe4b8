#include "bus/bus_server.h"

#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <array>
#include <optional>
#include <stdexcept>

#include "base/fnv_hash.h"
#include "base/monotonic_clock.h"
#include "bus/thread_slice.h"

namespace doppel::bus {
namespace {

constexpr int64_t kWriteRetryNs = 1'000'000;  // retry period while the client's queue is full

void add(std::atomic<uint64_t>& counter, uint64_t n = 1) noexcept {
  // Single writer (the bus thread): a plain load/store pair is enough and avoids a locked RMW.
  counter.store(counter.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
}

void set_if_changed(std::atomic<uint64_t>& counter, uint64_t value) noexcept {
  if (counter.load(std::memory_order_relaxed) != value) counter.store(value, std::memory_order_relaxed);
}

const BusServerOptions& validated(const BusServerOptions& options) {
  if (options.spin_ns < 0 || options.late_threshold_ns < 0 || options.idle_wait_ns <= 0 || options.slice_ns < 0) {
    throw std::invalid_argument("BusServer: spin_ns, late_threshold_ns and slice_ns must be >= 0, idle_wait_ns > 0");
  }
  return options;
}

}  // namespace

BusServer::BusServer(PtyPort& port, dynamixel::BusDevices& devices, const BusServerOptions& options,
                     DeviceSync* sync)
    : port_(port),
      devices_(devices),
      sync_(sync),
      options_(validated(options)),
      spin_budget_(options.spin_budget != nullptr ? *options.spin_budget : SpinBudget::process()),
      timing_(options.timing_mode, options.processing_ns),
      adapter_(options.timing_mode == TimingMode::kFast || options.adapter == AdapterProfile::kUsb2ax
                   ? 0
                   : options.adapter_latency_ms) {
  if (options.adapter_latency_ms > AdapterLatency::kMaxLatencyMs) {
    throw std::invalid_argument("BusServer: adapter_latency_ms must be 0..255");
  }
  requested_latency_ms_.store(options.adapter_latency_ms, std::memory_order_relaxed);
  if (options.adapter == AdapterProfile::kUsb2ax && options.timing_mode == TimingMode::kWire) {
    host_delay_ns_ = usb2ax_.send_timeout_ns();
  }
}

bool BusServer::set_adapter_latency_ms(uint32_t latency_ms) noexcept {
  if (latency_ms > AdapterLatency::kMaxLatencyMs) return false;
  requested_latency_ms_.store(latency_ms, std::memory_order_relaxed);
  return true;
}

uint32_t BusServer::adapter_latency_ms() const noexcept { return requested_latency_ms_.load(std::memory_order_relaxed); }

void BusServer::run(const std::atomic<bool>& stop) noexcept {
  // Timer slack (default 50 µs) would otherwise delay every timed wake-up by up to that much.
  const int old_slack = ::prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0);
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  const std::optional<uint64_t> old_slice =
      options_.slice_ns > 0 ? request_thread_slice_ns(static_cast<uint64_t>(options_.slice_ns)) : std::nullopt;
  while (!stop.load(std::memory_order_acquire)) run_once(options_.idle_wait_ns);
  if (old_slice) request_thread_slice_ns(*old_slice);
  if (old_slack > 0) ::prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(old_slack), 0, 0, 0);
}

int64_t BusServer::now() const noexcept {
  return options_.clock != nullptr ? options_.clock->load(std::memory_order_acquire) : monotonic_now_ns();
}

void BusServer::hash_bytes(uint8_t direction, int64_t t_ns, const uint8_t* bytes, std::size_t n) noexcept {
  // Folded per byte run with its time, so that how the pty split the bytes into reads does not matter.
  if (direction != hashed_direction_ || t_ns != hashed_ns_) {
    options_.hash->add_u8(direction);
    options_.hash->add_i64(t_ns);
    hashed_direction_ = direction;
    hashed_ns_ = t_ns;
  }
  options_.hash->add(bytes, n);
}

void BusServer::serve_lockstep(uint64_t input_total, int64_t settle_ns, bool check_line) noexcept {
  tick();
  if (!port_.connected()) {
    if (!check_line && input_total <= counters_.bytes_in.load(std::memory_order_relaxed)) return;
    if (!port_.poll_client()) return;
    on_connect();
  }
  if (!check_line && counters_.bytes_in.load(std::memory_order_relaxed) >= input_total) {
    write_blocked_ = false;
    write_due();
    return;
  }
  // The pty hands the controller's bytes over asynchronously (a kernel work item): wait for all of
  // them. A read of the master runs a pending hand-over first (n_tty_read flushes the port's work
  // item), so no poll precedes it; it stops at `input_total`, sparing the read that would find nothing.
  int64_t give_up = 0;
  for (;;) {
    // With all of it read already (check_line), the read takes whatever else the line holds.
    const bool all_in = counters_.bytes_in.load(std::memory_order_relaxed) >= input_total;
    read_input(all_in ? UINT64_MAX : input_total);
    if (port_.hung_up()) {
      on_hang_up();
      return;
    }
    if (counters_.bytes_in.load(std::memory_order_relaxed) >= input_total) break;
    const int64_t wall_ns = monotonic_now_ns();
    if (give_up == 0) give_up = wall_ns + settle_ns;
    if (wall_ns > give_up) break;
    port_.wait(100'000, false);
  }
  write_blocked_ = false;
  write_due();
}

int64_t BusServer::next_due_ns() const noexcept {
  return schedule_.empty() || write_blocked_ ? INT64_MAX : schedule_.front_due_ns();
}

void BusServer::tick() noexcept {
  if (sync_ == nullptr) return;
  const int64_t t = now();
  if (t - last_tick_ns_ < kTickNs) return;
  last_tick_ns_ = t;
  sync_->on_tick();
}

void BusServer::run_once(int64_t max_wait_ns) noexcept {
  tick();
  if (!port_.connected()) {
    if (port_.wait_for_client(std::min(max_wait_ns, kTickNs))) on_connect();
    return;
  }
  if (sync_ != nullptr) max_wait_ns = std::min(max_wait_ns, kTickNs);
  write_due();

  // Sleep until input arrives or the next delivery is due (shortly before, if it can spin the rest).
  int64_t wait_ns = std::max<int64_t>(max_wait_ns, 0);
  if (!schedule_.empty() && !write_blocked_) {
    const int64_t lead_ns = spin_budget_.has_free_slot() ? options_.spin_ns : 0;
    wait_ns = std::clamp(schedule_.front_due_ns() - now() - lead_ns, int64_t{0}, wait_ns);
  }
  if (write_blocked_) wait_ns = std::min(wait_ns, kWriteRetryNs);
  const PortWait woke = port_.wait(wait_ns, write_blocked_);
  // A pty master does not reliably report POLLOUT once the client drains its queue, so a blocked
  // write is simply retried after every wake-up (at least every kWriteRetryNs).
  write_blocked_ = false;
  if (woke.readable) read_input();
  if (port_.hung_up()) {
    on_hang_up();
    return;
  }

  if (!schedule_.empty() && !write_blocked_) {
    const int64_t due_ns = schedule_.front_due_ns();
    if (due_ns - now() <= options_.spin_ns) await_due(due_ns);
    write_due();
  }
}

void BusServer::await_due(int64_t due_ns) noexcept {
  // Close to the due time: spin the rest for accuracy if a core is free for it, else sleep to the
  // due time itself. Input that wakes the sleep early is read on the next pass.
  if (spin_budget_.try_acquire()) {
    while (now() < due_ns) {
    }
    spin_budget_.release();
    return;
  }
  const int64_t left_ns = due_ns - now();
  if (left_ns > 0) port_.wait(left_ns, false);
}

void BusServer::read_input(uint64_t until_total) noexcept {
  std::array<uint8_t, 4096> buffer;
  for (;;) {
    if (counters_.bytes_in.load(std::memory_order_relaxed) >= until_total) break;
    const std::size_t n = port_.read(buffer.data(), buffer.size());
    if (n == 0) break;
    const int64_t seen_ns = now();
    const uint32_t baud_bps = port_.line_baud_bps();
    counters_.line_baud_bps.store(baud_bps, std::memory_order_relaxed);
    add(counters_.bytes_in, n);
    if (options_.hash != nullptr) hash_bytes(0, seen_ns, buffer.data(), n);
    process(buffer.data(), n, seen_ns, baud_bps);
  }
}

void BusServer::process(const uint8_t* bytes, std::size_t n, int64_t seen_ns, uint32_t baud_bps) noexcept {
  // Firmware drops a packet whose bytes stop for more than 100 ms (P1) / 1.5 ms (P2). Checking
  // when the next bytes come is equivalent: a dropped partial packet has no effect until then. The
  // gap is counted from when the previous bytes had crossed the wire, not from when Doppel read
  // them (a pty hands a whole write over at once).
  const int64_t timeout_ns = parser_.receiving_protocol2() ? kP2InterByteTimeoutNs : kInterByteTimeoutNs;
  if (!parser_.idle() && seen_ns - last_input_ns_ > timeout_ns) {
    parser_.reset();
    add(counters_.timeouts);
    tap(TapEventKind::kTimeout, seen_ns);
  }
  const WireSpan span = timing_.host_bytes(seen_ns, n, baud_bps);
  last_input_ns_ = std::max(seen_ns, span.end_ns);
  const uint64_t offset = stream_offset_;
  stream_offset_ += n;
  if (options_.tap != nullptr) {
    TapEvent event;
    event.kind = TapEventKind::kInput;
    event.baud_bps = baud_bps;
    event.value = span.baud_bps;  // 0 in fast mode: the bytes take no wire time
    event.sequence = offset;
    event.t0_ns = seen_ns;
    event.t1_ns = span.start_ns;
    options_.tap->push(event, {bytes, n});
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (parser_.push(bytes[i]) == dynamixel::PacketFramer::Result::kPacket) {
      dispatch(parser_.packet(), span.byte_end_ns(i), seen_ns, baud_bps, offset + i + 1);
    }
  }
  const dynamixel::ParserCounters parsed = parser_.counters();
  set_if_changed(counters_.packets, parsed.packets);
  set_if_changed(counters_.bad_checksums, parsed.bad_checksums);
  set_if_changed(counters_.dropped_bytes, parsed.dropped_bytes);
}

void BusServer::tap(TapEventKind kind, int64_t t0_ns, int64_t t1_ns, std::span<const uint8_t> payload,
                    uint32_t value) noexcept {
  if (options_.tap == nullptr) return;
  TapEvent event;
  event.kind = kind;
  event.sequence = sequence_;
  event.t0_ns = t0_ns;
  event.t1_ns = t1_ns;
  event.value = value;
  options_.tap->push(event, payload);
}

void BusServer::dispatch(const dynamixel::InstructionPacket& packet, int64_t instruction_end_ns, int64_t seen_ns,
                         uint32_t baud_bps, uint64_t stream_end) noexcept {
  sequence_ = next_sequence_++;
  if (options_.tap != nullptr) {
    TapEvent event;
    event.kind = TapEventKind::kInstruction;
    event.protocol = packet.protocol == dynamixel::Protocol::kV2 ? 2 : 1;
    event.checksum_ok = packet.checksum_ok;
    event.baud_bps = baud_bps;
    event.value = packet.wire_bytes;
    event.sequence = sequence_;
    event.stream_end = stream_end;
    event.t0_ns = instruction_end_ns;
    event.t1_ns = seen_ns;
    options_.tap->push(event);
  }
  if (options_.adapter == AdapterProfile::kUsb2ax && usb2ax_intercepts(packet, seen_ns, baud_bps)) return;
  if (sync_ != nullptr) sync_->before_dispatch();
  std::span<const dynamixel::OutgoingStatus> statuses = devices_.dispatch(packet, baud_bps);
  if (sync_ != nullptr) {
    sync_->after_dispatch();
    statuses = sync_->impair(packet, statuses);
  }
  if (statuses.empty()) return;

  std::size_t total = 0;
  for (const auto& status : statuses) total += status.packet != nullptr ? status.packet->size : 0;
  if (total == 0) return;
  if (!schedule_.can_accept(total)) {
    add(counters_.dropped_replies);
    tap(TapEventKind::kReplyDropped, seen_ns);
    return;
  }

  timing_.begin_reply(instruction_end_ns);
  if (options_.timing_mode == TimingMode::kWire && options_.adapter == AdapterProfile::kFtdi) {
    adapter_.set_latency_ms(requested_latency_ms_.load(std::memory_order_relaxed));  // between replies: nothing buffered
  }
  adapter_.begin_reply();
  uint64_t merged = 0;
  int64_t due_ns = 0;
  auto emit = [&](const Delivery& delivery) noexcept {
    due_ns = std::max(due_ns, delivery.due_ns + host_delay_ns_);
    if (!schedule_.push_segment(delivery.due_ns + host_delay_ns_, delivery.count)) ++merged;
  };
  ReplyTrace trace;
  trace.seen_ns = seen_ns;
  trace.instruction_end_ns = instruction_end_ns;
  trace.bytes = static_cast<uint32_t>(total);
  trace.line_baud_bps = baud_bps;
  trace.id = packet.id;
  trace.instruction = packet.instruction;
  trace.sequence = sequence_;
  for (const auto& status : statuses) {
    if (status.packet == nullptr || status.packet->size == 0) continue;
    const std::size_t size = status.packet->size;
    schedule_.push_bytes(status.packet->bytes.data(), size);
    const WireSpan span = timing_.status(size, status.return_delay_us, status.after_previous, baud_bps,
                                         status.extra_delay_ns, status.continues_previous);
    trace.status_end_ns = span.end_ns;
    adapter_.add_status(span, size, emit);
    tap(TapEventKind::kStatus, span.start_ns, span.end_ns, {status.packet->bytes.data(), size}, status.return_delay_us);
  }
  adapter_.end_reply(emit);
  schedule_.mark_reply_end(trace);
  tap(TapEventKind::kReply, due_ns, 0, {}, adapter_.latency_ms());
  add(counters_.replies);
  if (merged != 0) add(counters_.merged_segments, merged);
}

void BusServer::write_due() noexcept {
  while (!schedule_.empty() && !write_blocked_) {
    const auto pending = schedule_.due_bytes(now());
    if (pending.empty()) return;
    const std::size_t written = port_.write(pending.data(), pending.size());
    if (written == 0) {
      // Full client queue (or the client just left: the next read reports the hang-up).
      write_blocked_ = true;
      return;
    }
    add(counters_.bytes_out, written);
    if (written < pending.size()) write_blocked_ = true;
    const int64_t written_ns = now();
    if (options_.hash != nullptr) hash_bytes(1, written_ns, pending.data(), written);
    for (std::size_t left = written; left > 0;) {
      const ReplySchedule::Progress progress = schedule_.consume(left);
      if (progress.bytes == 0) break;
      left -= progress.bytes;
      if (progress.segment_done) account_delivery(progress, written_ns);
    }
  }
}

void BusServer::account_delivery(const ReplySchedule::Progress& progress, int64_t written_ns) noexcept {
  const int64_t lateness_ns = written_ns - progress.due_ns;
  if (lateness_ns > options_.late_threshold_ns) add(counters_.late_deliveries);
  const auto bin = static_cast<std::size_t>(std::clamp<int64_t>(lateness_ns / kLatenessBinNs, 0, kLatenessBins - 1));
  add(counters_.lateness_bins[bin]);
  if (lateness_ns > counters_.max_lateness_ns.load(std::memory_order_relaxed)) {
    counters_.max_lateness_ns.store(lateness_ns, std::memory_order_relaxed);
  }
  if (progress.reply_done && options_.record_traces) {
    ReplyTrace trace = progress.trace;
    trace.due_ns = progress.due_ns;
    trace.written_ns = written_ns;
    traces_.try_push(trace);
  }
  if (progress.reply_done && options_.tap != nullptr) {
    TapEvent event;
    event.kind = TapEventKind::kDelivered;
    event.sequence = progress.trace.sequence;
    event.t0_ns = written_ns;
    options_.tap->push(event);
  }
}

void BusServer::on_connect() noexcept {
  timing_.reset();
  adapter_.reset();
  if (!parser_.idle()) parser_.reset();
  write_blocked_ = false;
  add(counters_.connects);
  tap(TapEventKind::kConnect, now());
  counters_.connected.store(true, std::memory_order_relaxed);
}

void BusServer::on_hang_up() noexcept {
  // Complete packets of the departed client were served by read_input; what is left is a partial
  // packet (dropped, as a servo would after its timeout) and replies nobody will read.
  if (!parser_.idle()) parser_.reset();
  tap(TapEventKind::kHangUp, now());
  add(counters_.discarded_bytes, schedule_.pending_bytes());
  schedule_.clear();
  adapter_.reset();
  timing_.reset();
  write_blocked_ = false;
  port_.disconnect();
  add(counters_.reconnects);
  counters_.connected.store(false, std::memory_order_relaxed);
}

int64_t lateness_quantile_ns(const BusDiagnostics& diagnostics, double q) noexcept {
  uint64_t total = 0;
  for (uint64_t count : diagnostics.lateness_bins) total += count;
  if (total == 0) return 0;
  const auto rank = static_cast<uint64_t>(std::ceil(q * static_cast<double>(total)));
  uint64_t seen = 0;
  for (std::size_t i = 0; i < kLatenessBins; ++i) {
    seen += diagnostics.lateness_bins[i];
    if (seen >= rank) return static_cast<int64_t>(i + 1) * kLatenessBinNs;
  }
  return static_cast<int64_t>(kLatenessBins) * kLatenessBinNs;
}

BusDiagnostics BusServer::diagnostics() const noexcept {
  const auto load = [](const auto& counter) { return counter.load(std::memory_order_relaxed); };
  BusDiagnostics d;
  d.packets = load(counters_.packets);
  d.bad_checksums = load(counters_.bad_checksums);
  d.bytes_in = load(counters_.bytes_in);
  d.bytes_out = load(counters_.bytes_out);
  d.dropped_bytes = load(counters_.dropped_bytes);
  d.timeouts = load(counters_.timeouts);
  d.connects = load(counters_.connects);
  d.reconnects = load(counters_.reconnects);
  d.replies = load(counters_.replies);
  d.dropped_replies = load(counters_.dropped_replies);
  d.merged_segments = load(counters_.merged_segments);
  d.discarded_bytes = load(counters_.discarded_bytes);
  d.late_deliveries = load(counters_.late_deliveries);
  for (std::size_t i = 0; i < kLatenessBins; ++i) d.lateness_bins[i] = load(counters_.lateness_bins[i]);
  d.max_lateness_ns = load(counters_.max_lateness_ns);
  d.line_baud_bps = load(counters_.line_baud_bps);
  d.connected = load(counters_.connected);
  return d;
}

}  // namespace doppel::bus
