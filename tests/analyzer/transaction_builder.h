#pragma once
// Recorded bus transactions for the analyzer's tests, laid out by hand rules rather than by the
// bus' wire model: a byte takes 10 bit times, the host's bytes start when it wrote them (or when
// the line is free), a status starts firmware time + Return Delay Time after the instruction (or,
// chained, after the previous status), and the host has it `adapter_ns` after its last byte.

#include <cstdint>
#include <string>
#include <vector>

#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"
#include "proto/recording.pb.h"

namespace doppel::analyzer::testing {

using Bytes = std::vector<uint8_t>;

inline Bytes p2_instruction(uint8_t id, uint8_t code, const Bytes& params) {
  Bytes out(params.size() * 2 + 16);
  out.resize(dynamixel::encode_protocol2_instruction(id, code, params.data(), params.size(), out.data(), out.size()));
  return out;
}

inline Bytes p1_instruction(uint8_t id, uint8_t code, const Bytes& params) {
  Bytes out(params.size() + 8);
  out.resize(dynamixel::encode_protocol1_instruction(id, code, params.data(), params.size(), out.data(), out.size()));
  return out;
}

inline Bytes p2_status(uint8_t id, const Bytes& data) {
  dynamixel::StatusPacket packet;
  dynamixel::encode_protocol2_status(id, 0, data.data(), data.size(), packet);
  return Bytes(packet.bytes.begin(), packet.bytes.begin() + packet.size);
}

inline Bytes p1_status(uint8_t id, const Bytes& data) {
  dynamixel::StatusPacket packet;
  dynamixel::encode_protocol1_status(id, 0, data.data(), data.size(), packet);
  return Bytes(packet.bytes.begin(), packet.bytes.begin() + packet.size);
}

struct StatusSpec {
  uint8_t id = 0;
  Bytes bytes;
  uint32_t return_delay_us = 0;
};

// Builds the transactions of one bus in wire order.
class TransactionBuilder {
 public:
  TransactionBuilder(uint32_t bus, uint32_t protocol, uint32_t baud_bps, int64_t processing_ns)
      : bus_(bus), protocol_(protocol), baud_bps_(baud_bps), processing_ns_(processing_ns) {}

  int64_t byte_ns(std::size_t n) const { return static_cast<int64_t>(n) * 10'000'000'000 / baud_bps_; }

  // The driver writes `instruction` at `written_ns`; `chained`: each status after the previous one.
  recording::BusTransaction& add(int64_t written_ns, const Bytes& instruction, const std::vector<StatusSpec>& statuses,
                                 bool chained = false, int64_t adapter_ns = 0, int64_t lateness_ns = 0) {
    recording::BusTransaction t;
    t.set_robot(0);
    t.set_bus(bus_);
    t.set_sequence(sequence_++);
    t.set_protocol(protocol_);
    t.set_instruction(std::string(instruction.begin(), instruction.end()));
    t.set_checksum_ok(true);
    t.set_baud_bps(baud_bps_);
    t.set_first_seen_ns(written_ns);
    t.set_seen_ns(written_ns);
    const int64_t start = std::max(written_ns, free_ns_);
    const int64_t end = start + byte_ns(instruction.size());
    t.set_instruction_start_ns(start);
    t.set_instruction_end_ns(end);
    int64_t previous = end;
    for (std::size_t i = 0; i < statuses.size(); ++i) {
      const StatusSpec& s = statuses[i];
      auto* status = t.add_statuses();
      status->set_id(s.id);
      status->set_bytes(std::string(s.bytes.begin(), s.bytes.end()));
      const int64_t origin = (chained && i > 0) ? previous : end;
      const int64_t status_start = std::max(previous, origin + processing_ns_ + int64_t{s.return_delay_us} * 1000);
      status->set_start_ns(status_start);
      status->set_end_ns(status_start + byte_ns(s.bytes.size()));
      status->set_return_delay_us(s.return_delay_us);
      previous = status->end_ns();
    }
    free_ns_ = previous;
    if (!statuses.empty()) {
      t.set_due_ns(previous + adapter_ns);
      t.set_written_ns(previous + adapter_ns + lateness_ns);
    }
    t.set_adapter("ftdi");
    transactions_.push_back(t);
    return transactions_.back();
  }

  // When the driver has the reply of the last transaction (or its last byte crossed).
  int64_t last_done_ns() const {
    const auto& t = transactions_.back();
    return t.written_ns() != 0 ? t.written_ns() : t.instruction_end_ns();
  }

  std::vector<recording::BusTransaction>& transactions() { return transactions_; }

 private:
  uint32_t bus_;
  uint32_t protocol_;
  uint32_t baud_bps_;
  int64_t processing_ns_;
  uint64_t sequence_ = 0;
  int64_t free_ns_ = 0;
  std::vector<recording::BusTransaction> transactions_;
};

}  // namespace doppel::analyzer::testing
