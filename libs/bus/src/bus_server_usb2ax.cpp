// BusServer with a USB2AX between host and bus (AdapterProfile::kUsb2ax): what the adapter answers
// itself and how long its SYNC READ takes on the wire. The protocol decisions are
// dynamixel::Usb2axFirmware's; this file adds the devices' answers and time.
#include <algorithm>
#include <array>

#include "bus/bus_server.h"

namespace doppel::bus {

using dynamixel::Usb2axFirmware;

bool BusServer::usb2ax_intercepts(const dynamixel::InstructionPacket& packet, int64_t seen_ns,
                                  uint32_t baud_bps) noexcept {
  const Usb2axFirmware::Action action = usb2ax_.handle(packet);
  if (action == Usb2axFirmware::Action::kPassThrough) return false;
  ReplyTrace trace;
  trace.seen_ns = seen_ns;
  trace.instruction_end_ns = seen_ns;  // the adapter has the packet once the USB transfer is in
  trace.line_baud_bps = baud_bps;
  trace.id = packet.id;
  trace.instruction = packet.instruction;
  trace.sequence = sequence_;
  if (action == Usb2axFirmware::Action::kSyncRead) {
    usb2ax_sync_read(seen_ns, baud_bps, trace);
    return true;
  }
  // A WRITE to its own ID may have changed the send timeout.
  if (options_.timing_mode == TimingMode::kWire) host_delay_ns_ = usb2ax_.send_timeout_ns();
  schedule_adapter_status(usb2ax_.status(), seen_ns + host_delay_ns_, trace);
  return action == Usb2axFirmware::Action::kAnswer;
}

void BusServer::usb2ax_sync_read(int64_t start_ns, uint32_t baud_bps, ReplyTrace trace) noexcept {
  // axGetRegister for each servo in turn: its READ crosses the wire, then axReadPacket waits for
  // the answer, each byte within USART_TIMEOUT of the previous one (of the READ's end for the
  // first). A missing or short answer costs the timeout after the last byte that came.
  const bool wire = options_.timing_mode == TimingMode::kWire;
  const int64_t timeout_ns = usb2ax_.usart_timeout_ns();
  const int64_t byte_ns = wire ? wire_duration_ns(1, baud_bps) : 0;
  int64_t t_ns = std::max(start_ns, wire ? timing_.wire_free_at_ns() : start_ns);
  if (sync_ != nullptr) sync_->before_dispatch();
  for (std::size_t i = 0; i < usb2ax_.servo_count(); ++i) {
    const int64_t read_end_ns = t_ns + (wire ? wire_duration_ns(Usb2axFirmware::kServoReadBytes, baud_bps) : 0);
    const auto statuses = devices_.dispatch(usb2ax_.servo_read(i), baud_bps);
    // The bytes the adapter's UART receives: the statuses on the wire in order, up to its buffer.
    std::array<uint8_t, 128> received;
    std::size_t n = 0;
    uint32_t first_delay_us = 0;
    for (const auto& status : statuses) {
      if (status.packet == nullptr) continue;
      if (n == 0) first_delay_us = status.return_delay_us;
      const std::size_t take = std::min<std::size_t>(status.packet->size, received.size() - n);
      std::copy_n(status.packet->bytes.begin(), take, received.begin() + static_cast<std::ptrdiff_t>(n));
      n += take;
    }
    const int64_t first_byte_ns =
        read_end_ns + (wire ? timing_.processing_ns() + int64_t{first_delay_us} * 1000 + byte_ns : 0);
    const bool in_time = n > 0 && first_byte_ns - read_end_ns <= timeout_ns && byte_ns <= timeout_ns;
    const std::size_t expected = usb2ax_.expected_answer_bytes();
    if (!in_time) {
      usb2ax_.add_servo_answer(nullptr, 0);
      t_ns = read_end_ns + (wire ? timeout_ns : 0);
      continue;
    }
    usb2ax_.add_servo_answer(received.data(), n);
    const std::size_t arrived = std::min(n, expected);
    t_ns = first_byte_ns + (wire ? wire_duration_ns(arrived - 1, baud_bps) : 0);
    if (n < expected && wire) t_ns += timeout_ns;  // waited for bytes that never came
  }
  if (sync_ != nullptr) sync_->after_dispatch();
  if (wire) timing_.hold_until(t_ns);
  trace.status_end_ns = t_ns;
  schedule_adapter_status(usb2ax_.finish_sync_read(), t_ns + host_delay_ns_, trace);
}

void BusServer::schedule_adapter_status(const dynamixel::StatusPacket& status, int64_t due_ns,
                                        ReplyTrace trace) noexcept {
  if (status.size == 0) return;
  if (!schedule_.can_accept(status.size)) {
    counters_.dropped_replies.store(counters_.dropped_replies.load(std::memory_order_relaxed) + 1,
                                    std::memory_order_relaxed);
    tap(TapEventKind::kReplyDropped, due_ns);
    return;
  }
  schedule_.push_bytes(status.bytes.data(), status.size);
  schedule_.push_segment(due_ns, status.size);
  trace.bytes = status.size;
  if (trace.status_end_ns == 0) trace.status_end_ns = due_ns;
  schedule_.mark_reply_end(trace);
  // The adapter's own answer: on the USB side only, so its wire span is empty at the due time.
  tap(TapEventKind::kStatus, due_ns, due_ns, {status.bytes.data(), status.size});
  tap(TapEventKind::kReply, due_ns);
  counters_.replies.store(counters_.replies.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

}  // namespace doppel::bus
