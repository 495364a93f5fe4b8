#pragma once
// Protocol 2.0 for the reference client, written from shared/reference/dynamixel.md §2 (CRC-16
// in its bitwise form, byte stuffing as the reference states it, the status layout and the FAST
// SYNC/BULK READ combined status), not from Doppel's codec, so that a misreading shared by
// Doppel's encoder and decoder cannot pass unnoticed. I/O goes through SerialClient.

#include <cstdint>
#include <optional>
#include <vector>

#include "reference_client.h"

namespace doppel::testing {

// CRC-16 of §2.2, bitwise: crc ^= byte << 8; 8 x: crc = crc & 0x8000 ? (crc << 1) ^ 0x8005 : crc << 1.
uint16_t p2_crc(const uint8_t* bytes, std::size_t n, uint16_t crc = 0);

// FF FF FD 00 ID LEN INST params CRC, with an FD added after every FF FF FD of INST..params and
// LEN counting the added bytes (§2.1, §2.3).
Bytes p2_instruction(uint8_t id, uint8_t instruction, const Bytes& params = {});

// Little-endian helpers for building parameters.
Bytes le16(uint16_t value);
Bytes le32(int32_t value);
int32_t le32_at(const Bytes& bytes, std::size_t offset);

struct P2Status {
  uint8_t id = 0;
  uint8_t error = 0;  // ERR byte (bit 7 Alert, bits 6..0 error number)
  Bytes params;       // unstuffed
};

// Parses every complete status packet in `bytes` (header, reserved 00, INST 0x55, CRC over the
// bytes as received, then unstuffing); nullopt if any packet is malformed or bytes are left over.
std::optional<std::vector<P2Status>> parse_p2_statuses(const Bytes& bytes);

// Reads `count` status packets the way the SDK's rxPacket does: the 7-byte header, then as many
// bytes as its LEN field says, so that a status lengthened by byte stuffing (an FF FF FD in its
// data) is read whole. Returns what arrived within `timeout_ms` (short on a timeout, the first 7
// bytes only if they are not a status header).
Bytes receive_p2_statuses(SerialClient& client, std::size_t count, int timeout_ms);

// send() then receive_p2_statuses().
Bytes transact_p2(SerialClient& client, const Bytes& request, std::size_t count, int timeout_ms = 5000);

// One device's block of a FAST SYNC/BULK READ combined status (§2.7).
struct P2FastBlock {
  uint8_t error = 0;
  uint8_t id = 0;
  Bytes data;
};

// Parses a combined status whose blocks carry `lengths[k]` data bytes each: ID 0xFE, LEN =
// 1 + sum(X_k + 4), every block CRC = running CRC of the packet up to that block's data.
// nullopt on any mismatch.
std::optional<std::vector<P2FastBlock>> parse_p2_fast_status(const Bytes& bytes, const std::vector<std::size_t>& lengths);

// Status bytes as the reference frames them, for comparisons (stuffed like an instruction).
Bytes p2_status(uint8_t id, uint8_t error, const Bytes& params = {});

}  // namespace doppel::testing
