#include "bus/adapter_latency.h"

#include <gtest/gtest.h>

#include <ostream>
#include <stdexcept>
#include <vector>

namespace doppel::bus {

// Found by argument-dependent lookup, so they live in the type's namespace.
bool operator==(const Delivery& a, const Delivery& b) {
  return a.due_ns == b.due_ns && a.offset == b.offset && a.count == b.count;
}

void PrintTo(const Delivery& d, std::ostream* os) {
  *os << "{due " << d.due_ns << " ns, offset " << d.offset << ", count " << d.count << "}";
}

namespace {

constexpr int64_t kUs = 1'000;
constexpr int64_t kMs = 1'000'000;
constexpr uint32_t k1Mbps = 1'000'000;

WireSpan span_of(int64_t start_ns, std::size_t n, uint32_t baud) {
  return WireSpan{start_ns, start_ns + wire_duration_ns(n, baud), baud};
}

// Feeds one reply made of `statuses` (start, bytes) and returns the deliveries.
std::vector<Delivery> deliver(AdapterLatency& sut, std::initializer_list<std::pair<int64_t, std::size_t>> statuses,
                              uint32_t baud = k1Mbps) {
  std::vector<Delivery> out;
  auto emit = [&](const Delivery& d) { out.push_back(d); };
  sut.begin_reply();
  for (const auto& [start, n] : statuses) sut.add_status(span_of(start, n, baud), n, emit);
  sut.end_reply(emit);
  return out;
}

TEST(AdapterLatency, OffHandsEachStatusOverWhenItHasCrossed) {
  AdapterLatency sut(0);

  const auto out = deliver(sut, {{630 * kUs, 6}, {750 * kUs, 8}});

  EXPECT_EQ(out, (std::vector<Delivery>{{690 * kUs, 0, 6}, {830 * kUs, 6, 8}}));
}

// A PING status (6 bytes) ending at 0.69 ms waits for the next timer expiry: 16 ms with the FTDI
// default, 1 ms with the value teams set (reference §4.3).
TEST(AdapterLatency, ShortStatusWaitsForTheTimer) {
  AdapterLatency ftdi_default(AdapterLatency::kFtdiDefaultLatencyMs);
  AdapterLatency tuned(1);

  const auto slow = deliver(ftdi_default, {{630 * kUs, 6}});
  const auto fast = deliver(tuned, {{630 * kUs, 6}});

  EXPECT_EQ(slow, (std::vector<Delivery>{{16 * kMs, 0, 6}}));
  EXPECT_EQ(fast, (std::vector<Delivery>{{1 * kMs, 0, 6}}));
}

TEST(AdapterLatency, StatusStraddlingAnExpiryIsSplit) {
  AdapterLatency sut(1);

  // 8 bytes from 970 µs: bytes cross at 980, 990, 1000 (| expiry at 1 ms), 1010 ... 1050 µs.
  const auto out = deliver(sut, {{970 * kUs, 8}});

  EXPECT_EQ(out, (std::vector<Delivery>{{1 * kMs, 0, 3}, {2 * kMs, 3, 5}}));
}

// AN232B-04: a full buffer (62 payload bytes) is sent at once, and sending restarts the timer.
TEST(AdapterLatency, FullUsbPacketGoesAtOnceAndRestartsTheTimer) {
  AdapterLatency sut(16);

  const auto out = deliver(sut, {{0, 100}});

  EXPECT_EQ(out, (std::vector<Delivery>{{620 * kUs, 0, 62}, {16 * kMs + 620 * kUs, 62, 38}}));
}

TEST(AdapterLatency, ChainedStatusesShareTheAdapterBuffer) {
  AdapterLatency sut(16);

  // BULK READ replies at 1 Mbps: [180, 260] µs and [310, 390] µs.
  const auto out = deliver(sut, {{180 * kUs, 8}, {310 * kUs, 8}});

  EXPECT_EQ(out, (std::vector<Delivery>{{16 * kMs, 0, 16}}));
}

TEST(AdapterLatency, BufferFillsAcrossStatuses) {
  AdapterLatency sut(16);

  // 40 bytes over [0, 400] µs, then 40 bytes from 450 µs: the 62nd byte is the second status'
  // 22nd, crossing at 450 + 220 = 670 µs.
  const auto out = deliver(sut, {{0, 40}, {450 * kUs, 40}});

  EXPECT_EQ(out, (std::vector<Delivery>{{670 * kUs, 0, 62}, {16 * kMs + 670 * kUs, 62, 18}}));
}

TEST(AdapterLatency, TimerRunsFreelyBetweenReplies) {
  AdapterLatency sut(16);
  deliver(sut, {{630 * kUs, 6}});  // sent at the 16 ms expiry

  const auto next = deliver(sut, {{20 * kMs, 6}});
  const auto after_idle = deliver(sut, {{100 * kMs + 1, 6}});

  EXPECT_EQ(next, (std::vector<Delivery>{{32 * kMs, 0, 6}}));
  EXPECT_EQ(after_idle, (std::vector<Delivery>{{112 * kMs, 0, 6}}));
}

TEST(AdapterLatency, SlowLineWithShortTimerDeliversByteByByte) {
  AdapterLatency sut(1);

  // 9600 baud: 1.0417 ms per byte, longer than the 1 ms timer.
  const auto out = deliver(sut, {{0, 3}}, 9'600);

  EXPECT_EQ(out, (std::vector<Delivery>{{2 * kMs, 0, 1}, {3 * kMs, 1, 1}, {4 * kMs, 2, 1}}));
}

TEST(AdapterLatency, RejectsTimerAbove255Ms) {
  EXPECT_THROW(AdapterLatency(256), std::invalid_argument);
  EXPECT_NO_THROW(AdapterLatency(255));
}

}  // namespace
}  // namespace doppel::bus

namespace doppel::bus {
namespace {

// A driver writes the FTDI latency_timer file between two replies: the next status waits for the
// new period's expiry (16 ms -> 1 ms), and values outside 0..255 change nothing.
TEST(AdapterLatency, SetLatencyBetweenRepliesAppliesToTheNextReply) {
  AdapterLatency sut(16);
  EXPECT_EQ(deliver(sut, {{630 * kUs, 6}}), (std::vector<Delivery>{{16 * kMs, 0, 6}}));

  EXPECT_TRUE(sut.set_latency_ms(1));
  EXPECT_FALSE(sut.set_latency_ms(256));

  EXPECT_EQ(sut.latency_ms(), 1u);
  EXPECT_EQ(deliver(sut, {{20 * kMs + 630 * kUs, 6}}), (std::vector<Delivery>{{21 * kMs, 0, 6}}));
}

}  // namespace
}  // namespace doppel::bus
