#include "bus/wire_timing.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace doppel::bus {
namespace {

constexpr int64_t kUs = 1'000;

// Byte times from reference §4.1 (10 bit times per 8N1 byte), rounded up to whole ns.
TEST(WireDuration, ByteTimesMatchReference) {
  EXPECT_EQ(wire_duration_ns(1, 1'000'000), 10 * kUs);
  EXPECT_EQ(wire_duration_ns(1, 2'000'000), 5 * kUs);
  EXPECT_EQ(wire_duration_ns(1, 57'600), 173'612);     // 173.6 µs
  EXPECT_EQ(wire_duration_ns(1, 115'200), 86'806);     // 86.8 µs
  EXPECT_EQ(wire_duration_ns(1, 9'600), 1'041'667);    // 1041.7 µs
  EXPECT_EQ(wire_duration_ns(1, 4'500'000), 2'223);    // 2.22 µs
}

TEST(WireDuration, LongRunsDoNotAccumulateRounding) {
  // 57600 bytes at 57600 baud are exactly 10 s; summing rounded byte times would give 10.00006 s.
  EXPECT_EQ(wire_duration_ns(57'600, 57'600), 10'000'000'000);
  EXPECT_EQ(wire_duration_ns(0, 57'600), 0);
  EXPECT_EQ(wire_duration_ns(8, 0), 0);  // B0: no rate, no time
}

// An adapter that talks to the servos on its own (a USB2AX SYNC READ) holds the wire: host bytes
// seen meanwhile start crossing when it is done, never earlier, and an earlier hold changes nothing.
TEST(WireTiming, HostBytesWaitForAWireHeldByTheAdapter) {
  WireTiming sut(TimingMode::kWire, 0);
  sut.hold_until(1'000 * kUs);
  sut.hold_until(500 * kUs);
  const WireSpan ping = sut.host_bytes(100 * kUs, 6, 1'000'000);
  EXPECT_EQ(ping.start_ns, 1'000 * kUs);
  EXPECT_EQ(ping.end_ns, 1'060 * kUs);
}

// Reference §4.2: P1 READ of 2 bytes, 8 bytes out and 8 back, default RDT 500 µs: 0.66 ms at
// 1 Mbps when the device adds no processing time.
TEST(WireTiming, P1ReadAt1MbpsMatchesReferenceRoundTrip) {
  WireTiming sut(TimingMode::kWire, 0);

  const WireSpan instruction = sut.host_bytes(0, 8, 1'000'000);
  sut.begin_reply(instruction.end_ns);
  const WireSpan status = sut.status(8, 500, false, 1'000'000);

  EXPECT_EQ(instruction.end_ns, 80 * kUs);
  EXPECT_EQ(status.start_ns, 580 * kUs);
  EXPECT_EQ(status.end_ns, 660 * kUs);
}

TEST(WireTiming, P1ReadAt57600MatchesReferenceRoundTrip) {
  WireTiming sut(TimingMode::kWire, 0);

  const WireSpan instruction = sut.host_bytes(0, 8, 57'600);
  sut.begin_reply(instruction.end_ns);
  const WireSpan status = sut.status(8, 500, false, 57'600);

  // 8 × 173.61 µs = 1388.89 µs each way; reference: 3.28 ms including the 500 µs RDT.
  EXPECT_EQ(instruction.end_ns, 1'388'889);
  EXPECT_EQ(status.start_ns, 1'888'889);
  EXPECT_EQ(status.end_ns, 3'277'778);
}

TEST(WireTiming, ProcessingTimeComesBeforeReturnDelay) {
  WireTiming sut;  // default: wire mode, 50 µs firmware time (MX-64)

  const WireSpan instruction = sut.host_bytes(1'000 * kUs, 6, 1'000'000);  // PING, 6 bytes
  sut.begin_reply(instruction.end_ns);
  const WireSpan status = sut.status(6, 0, false, 1'000'000);

  EXPECT_EQ(sut.processing_ns(), 50 * kUs);
  EXPECT_EQ(instruction.end_ns, 1'060 * kUs);
  EXPECT_EQ(status.start_ns, 1'110 * kUs);
  EXPECT_EQ(status.end_ns, 1'170 * kUs);
}

TEST(WireTiming, PacketEndingInsideAChunkEndsAtItsLastByte) {
  WireTiming sut(TimingMode::kWire, 0);

  // Two PINGs (6 + 6 bytes) read in one chunk at t = 0: the first ends after 6 byte times.
  const WireSpan chunk = sut.host_bytes(0, 12, 1'000'000);

  EXPECT_EQ(chunk.byte_end_ns(5), 60 * kUs);
  EXPECT_EQ(chunk.byte_end_ns(11), 120 * kUs);
  EXPECT_EQ(chunk.end_ns, 120 * kUs);
}

TEST(WireTiming, HostBytesWaitForABusyWire) {
  WireTiming sut(TimingMode::kWire, 0);
  const WireSpan first = sut.host_bytes(0, 8, 1'000'000);
  sut.begin_reply(first.end_ns);
  sut.status(8, 500, false, 1'000'000);  // wire busy until 660 µs

  const WireSpan early = sut.host_bytes(600 * kUs, 6, 1'000'000);
  const WireSpan late = sut.host_bytes(2'000 * kUs, 6, 1'000'000);

  EXPECT_EQ(early.start_ns, 660 * kUs);
  EXPECT_EQ(early.end_ns, 720 * kUs);
  EXPECT_EQ(late.start_ns, 2'000 * kUs);
}

// BULK READ (reference §1.7): `FF FF FE 09 92 00 02 01 1E 02 02 24 1D` (13 bytes) answered by
// ID 1 and then, chained, ID 2 (8 bytes each).
TEST(WireTiming, ChainedStatusStartsAfterPreviousPlusProcessingAndOwnDelay) {
  WireTiming sut(TimingMode::kWire, 50 * kUs);

  const WireSpan instruction = sut.host_bytes(0, 13, 1'000'000);
  sut.begin_reply(instruction.end_ns);
  const WireSpan first = sut.status(8, 0, false, 1'000'000);
  const WireSpan second = sut.status(8, 10, true, 1'000'000);  // RDT 10 µs

  EXPECT_EQ(instruction.end_ns, 130 * kUs);
  EXPECT_EQ(first.start_ns, 180 * kUs);
  EXPECT_EQ(first.end_ns, 260 * kUs);
  EXPECT_EQ(second.start_ns, 320 * kUs);  // 260 + 50 + 10
  EXPECT_EQ(second.end_ns, 400 * kUs);
  EXPECT_EQ(sut.wire_free_at_ns(), 400 * kUs);
}

TEST(WireTiming, UnchainedStatusesNeverOverlapOnTheWire) {
  WireTiming sut(TimingMode::kWire, 0);
  sut.begin_reply(100 * kUs);

  const WireSpan first = sut.status(8, 0, false, 1'000'000);
  const WireSpan second = sut.status(8, 0, false, 1'000'000);

  EXPECT_EQ(first.start_ns, 100 * kUs);
  EXPECT_EQ(second.start_ns, first.end_ns);
}

TEST(WireTiming, FastModeAddsNoDelay) {
  WireTiming sut(TimingMode::kFast, 50 * kUs);

  const WireSpan instruction = sut.host_bytes(7 * kUs, 8, 57'600);
  sut.begin_reply(instruction.byte_end_ns(7));
  const WireSpan status = sut.status(8, 500, false, 57'600);

  EXPECT_EQ(instruction.byte_end_ns(7), 7 * kUs);
  EXPECT_EQ(status.start_ns, 7 * kUs);
  EXPECT_EQ(status.end_ns, 7 * kUs);
}

TEST(WireTiming, ResetFreesTheWire) {
  WireTiming sut(TimingMode::kWire, 0);
  sut.host_bytes(0, 100, 9'600);

  sut.reset();
  const WireSpan next = sut.host_bytes(5, 1, 9'600);

  EXPECT_EQ(next.start_ns, 5);
}

TEST(WireTiming, RejectsNegativeProcessingTime) {
  EXPECT_THROW(WireTiming(TimingMode::kWire, -1), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::bus
