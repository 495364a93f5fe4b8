#pragma once
// One recorded bus transaction as the analyzer keeps it: the fields of
// recording::BusTransaction it uses, with each status reduced to its ID, size and times. A
// recording holds hundreds of thousands of transactions of up to dozens of statuses each: kept as
// protobuf messages, a report on 200 000 Bit-Bots transactions (20 statuses each) took 535 MB,
// this way 225 MB (docs/analyzer.md).

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "proto/recording.pb.h"

namespace doppel::analyzer {

struct StatusRecord {
  int64_t start_ns = 0;          // model: first byte on the wire
  int64_t end_ns = 0;            // model: last byte crossed
  uint32_t return_delay_us = 0;  // the device's Return Delay Time when it answered
  uint16_t bytes = 0;            // wire bytes
  uint8_t id = 0;                // the answering device
};

struct Transaction {
  uint32_t robot = 0;
  uint32_t bus = 0;
  uint64_t sequence = 0;           // per bus from 0; a gap means the recorder dropped transactions
  uint32_t protocol = 0;           // 1 or 2
  uint32_t baud_bps = 0;           // line rate the driver had set
  uint32_t adapter_latency_ms = 0; // the adapter's latency timer for this reply
  bool checksum_ok = true;         // false: framed with a wrong checksum / CRC
  bool reply_dropped = false;      // a status was due but the driver was not reading
  bool usb2ax = false;             // the adapter was a USB2AX (else FTDI)
  int64_t first_seen_ns = 0;       // Doppel read the first byte of the packet
  int64_t seen_ns = 0;             // and the last
  int64_t instruction_start_ns = 0;  // model: first byte on the wire
  int64_t instruction_end_ns = 0;    // model: last byte crossed
  int64_t due_ns = 0;              // model: the driver has the last status byte (0: no status)
  int64_t written_ns = 0;          // Doppel wrote the last status byte (0: not delivered)
  std::string instruction;         // the packet's bytes as the driver wrote them
  std::vector<StatusRecord> statuses;  // in wire order
};

// The analyzer's copy of a recorded transaction. Status sizes above 65535 bytes (no Dynamixel
// packet is that long) are clamped.
Transaction compact(const recording::BusTransaction& message);
std::vector<Transaction> compact(std::span<const recording::BusTransaction> messages);

}  // namespace doppel::analyzer
