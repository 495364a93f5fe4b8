#include "analyzer/transaction.h"

#include <algorithm>

namespace doppel::analyzer {

Transaction compact(const recording::BusTransaction& m) {
  Transaction t;
  t.robot = m.robot();
  t.bus = m.bus();
  t.sequence = m.sequence();
  t.protocol = m.protocol();
  t.baud_bps = m.baud_bps();
  t.adapter_latency_ms = m.adapter_latency_ms();
  t.checksum_ok = m.checksum_ok();
  t.reply_dropped = m.reply_dropped();
  t.usb2ax = m.adapter() == "usb2ax";
  t.first_seen_ns = m.first_seen_ns();
  t.seen_ns = m.seen_ns();
  t.instruction_start_ns = m.instruction_start_ns();
  t.instruction_end_ns = m.instruction_end_ns();
  t.due_ns = m.due_ns();
  t.written_ns = m.written_ns();
  t.instruction = m.instruction();
  t.statuses.reserve(static_cast<std::size_t>(m.statuses_size()));
  for (const auto& s : m.statuses()) {
    StatusRecord r;
    r.start_ns = s.start_ns();
    r.end_ns = s.end_ns();
    r.return_delay_us = s.return_delay_us();
    r.bytes = static_cast<uint16_t>(std::min<std::size_t>(s.bytes().size(), 0xFFFF));
    r.id = static_cast<uint8_t>(std::min<uint32_t>(s.id(), 0xFF));
    t.statuses.push_back(r);
  }
  return t;
}

std::vector<Transaction> compact(std::span<const recording::BusTransaction> messages) {
  std::vector<Transaction> out;
  out.reserve(messages.size());
  for (const auto& m : messages) out.push_back(compact(m));
  return out;
}

}  // namespace doppel::analyzer
