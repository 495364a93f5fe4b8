#include "bus/reply_schedule.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace doppel::bus {
namespace {

// Hands over everything due by `now_ns`, in pieces of at most `max_write` bytes.
std::vector<uint8_t> drain(ReplySchedule& sut, int64_t now_ns, std::size_t max_write = SIZE_MAX) {
  std::vector<uint8_t> out;
  for (auto bytes = sut.due_bytes(now_ns); !bytes.empty(); bytes = sut.due_bytes(now_ns)) {
    const std::size_t n = std::min(bytes.size(), max_write);
    out.insert(out.end(), bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    for (std::size_t left = n; left > 0;) left -= sut.consume(left).bytes;  // segment by segment
  }
  return out;
}

TEST(ReplySchedule, ReleasesBytesOnlyWhenDue) {
  ReplySchedule sut;
  const uint8_t status[] = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  sut.push_bytes(status, 6);
  sut.push_segment(100, 4);
  sut.push_segment(200, 2);

  const auto at_50 = drain(sut, 50);
  const auto at_150 = drain(sut, 150);
  const auto at_250 = drain(sut, 250);

  EXPECT_TRUE(at_50.empty());
  EXPECT_EQ(at_150, (std::vector<uint8_t>{0xFF, 0xFF, 0x01, 0x02}));
  EXPECT_EQ(at_250, (std::vector<uint8_t>{0x00, 0xFC}));
  EXPECT_TRUE(sut.empty());
}

TEST(ReplySchedule, DueTimesNeverGoBackwards) {
  ReplySchedule sut;
  const uint8_t bytes[] = {1, 2};
  sut.push_bytes(bytes, 2);
  sut.push_segment(300, 1);
  sut.push_segment(100, 1);  // earlier than its predecessor: must not overtake it

  sut.consume(1);

  EXPECT_EQ(sut.front_due_ns(), 300);
}

TEST(ReplySchedule, StatusesOfOneReplyDueTogetherLeaveInOneWrite) {
  ReplySchedule sut;
  const uint8_t two_statuses[] = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC, 0xFF, 0xFF, 0x02, 0x02, 0x00, 0xFB};
  sut.push_bytes(two_statuses, sizeof two_statuses);
  sut.push_segment(100, 6);
  sut.push_segment(100, 6);

  EXPECT_EQ(sut.due_bytes(100).size(), sizeof two_statuses);
}

TEST(ReplySchedule, SegmentsThatFellDueTogetherLeaveInOneWriteAndCompleteInOrder) {
  ReplySchedule sut;
  const uint8_t bytes[] = {1, 2, 3, 4, 5};
  sut.push_bytes(bytes, 5);
  sut.push_segment(100, 2);
  sut.push_segment(200, 2);
  sut.push_segment(300, 1);

  const auto due_at_250 = sut.due_bytes(250);
  const ReplySchedule::Progress first = sut.consume(due_at_250.size());
  const ReplySchedule::Progress second = sut.consume(due_at_250.size() - first.bytes);

  EXPECT_EQ(std::vector<uint8_t>(due_at_250.begin(), due_at_250.end()), (std::vector<uint8_t>{1, 2, 3, 4}));
  EXPECT_TRUE(first.segment_done);
  EXPECT_EQ(first.due_ns, 100);
  EXPECT_TRUE(second.segment_done);
  EXPECT_EQ(second.due_ns, 200);
  EXPECT_EQ(sut.front_due_ns(), 300);
  EXPECT_TRUE(sut.due_bytes(299).empty());
}

TEST(ReplySchedule, ReplyEndsStayApartSoEachReplyIsTraced) {
  ReplySchedule sut;
  const uint8_t bytes[] = {1, 2};
  sut.push_bytes(bytes, 2);
  sut.push_segment(100, 1);
  ReplyTrace first;
  first.id = 1;
  sut.mark_reply_end(first);
  sut.push_segment(100, 1);
  ReplyTrace second;
  second.id = 2;
  sut.mark_reply_end(second);

  const ReplySchedule::Progress p1 = sut.consume(1);
  const ReplySchedule::Progress p2 = sut.consume(1);

  EXPECT_TRUE(p1.reply_done);
  EXPECT_EQ(p1.trace.id, 1);
  EXPECT_TRUE(p2.reply_done);
  EXPECT_EQ(p2.trace.id, 2);
}

TEST(ReplySchedule, PartialWritesKeepTheRestAndReportCompletion) {
  ReplySchedule sut;
  const uint8_t bytes[] = {1, 2, 3, 4, 5};
  sut.push_bytes(bytes, 5);
  sut.push_segment(10, 5);
  ReplyTrace trace;
  trace.id = 7;
  sut.mark_reply_end(trace);

  const auto first = sut.consume(2);
  const auto rest = sut.due_bytes(10);
  const auto second = sut.consume(3);

  EXPECT_FALSE(first.segment_done);
  EXPECT_EQ(std::vector<uint8_t>(rest.begin(), rest.end()), (std::vector<uint8_t>{3, 4, 5}));
  EXPECT_TRUE(second.segment_done);
  EXPECT_TRUE(second.reply_done);
  EXPECT_EQ(second.due_ns, 10);
  EXPECT_EQ(second.trace.id, 7);
}

TEST(ReplySchedule, BytesSurviveRingWrapAround) {
  ReplySchedule sut;
  std::vector<uint8_t> expected;
  std::vector<uint8_t> received;
  uint8_t next = 0;
  // Replies of 1000 bytes, always ~40 in flight: the 64 KiB ring wraps many times.
  for (int reply = 0; reply < 300; ++reply) {
    std::vector<uint8_t> bytes(1000);
    for (auto& b : bytes) b = next++;
    ASSERT_TRUE(sut.can_accept(bytes.size()));
    sut.push_bytes(bytes.data(), bytes.size());
    sut.push_segment(reply, 600);
    sut.push_segment(reply, 400);
    expected.insert(expected.end(), bytes.begin(), bytes.end());
    const auto out = drain(sut, reply - 40, 777);
    received.insert(received.end(), out.begin(), out.end());
  }
  const auto out = drain(sut, INT64_MAX, 777);
  received.insert(received.end(), out.begin(), out.end());

  EXPECT_EQ(received, expected);
}

TEST(ReplySchedule, RefusesWhatDoesNotFit) {
  ReplySchedule sut;
  std::vector<uint8_t> big(ReplySchedule::kByteCapacity - 10, 0xAA);
  sut.push_bytes(big.data(), big.size());
  sut.push_segment(0, big.size());

  EXPECT_TRUE(sut.can_accept(10));
  EXPECT_FALSE(sut.can_accept(11));
}

TEST(ReplySchedule, FullSegmentRingMergesIntoTheLastSegmentLateNotLost) {
  ReplySchedule sut;
  std::vector<uint8_t> bytes(ReplySchedule::kSegmentCapacity + 1, 0x55);
  sut.push_bytes(bytes.data(), bytes.size());
  for (std::size_t i = 0; i < ReplySchedule::kSegmentCapacity; ++i) {
    ASSERT_TRUE(sut.push_segment(static_cast<int64_t>(i), 1));
  }

  const bool separate = sut.push_segment(5'000, 1);

  EXPECT_FALSE(separate);
  EXPECT_TRUE(sut.can_accept(1));
  EXPECT_EQ(sut.pending_bytes(), bytes.size());
  EXPECT_EQ(drain(sut, 4'999).size(), ReplySchedule::kSegmentCapacity - 1);
  EXPECT_EQ(drain(sut, 5'000).size(), 2u);
}

TEST(ReplySchedule, ClearDropsEverything) {
  ReplySchedule sut;
  const uint8_t bytes[] = {1, 2, 3};
  sut.push_bytes(bytes, 3);
  sut.push_segment(0, 3);

  sut.clear();

  EXPECT_TRUE(sut.empty());
  EXPECT_EQ(sut.pending_bytes(), 0u);
  EXPECT_TRUE(sut.due_bytes(INT64_MAX).empty());
}

}  // namespace
}  // namespace doppel::bus
