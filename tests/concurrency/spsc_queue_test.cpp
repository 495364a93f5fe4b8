#include "concurrency/spsc_queue.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

namespace doppel::concurrency {
namespace {

TEST(SpscQueue, PopsInPushOrder) {
  SpscQueue<int, 4> sut;
  ASSERT_TRUE(sut.try_push(1));
  ASSERT_TRUE(sut.try_push(2));
  ASSERT_TRUE(sut.try_push(3));

  int a = 0, b = 0, c = 0;
  ASSERT_TRUE(sut.try_pop(a));
  ASSERT_TRUE(sut.try_pop(b));
  ASSERT_TRUE(sut.try_pop(c));

  EXPECT_EQ(a, 1);
  EXPECT_EQ(b, 2);
  EXPECT_EQ(c, 3);
}

TEST(SpscQueue, EmptyQueuePopsNothing) {
  SpscQueue<int, 4> sut;
  int value = 42;

  EXPECT_FALSE(sut.try_pop(value));
  EXPECT_EQ(value, 42);
  EXPECT_FALSE(sut.try_pop().has_value());
}

TEST(SpscQueue, FullQueueDropsAndCounts) {
  SpscQueue<int, 4> sut;
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(sut.try_push(i));

  const bool pushed = sut.try_push(99);
  const bool pushed_again = sut.try_push(100);

  EXPECT_FALSE(pushed);
  EXPECT_FALSE(pushed_again);
  EXPECT_EQ(sut.dropped(), 2u);
  EXPECT_EQ(sut.size_approx(), 4u);
  // The queued values are intact: the dropped ones did not overwrite anything.
  for (int i = 0; i < 4; ++i) EXPECT_EQ(sut.try_pop(), i);
}

TEST(SpscQueue, WrapsAroundManyTimes) {
  SpscQueue<uint32_t, 8> sut;
  uint32_t next_out = 0;
  for (uint32_t i = 0; i < 1000; ++i) {
    ASSERT_TRUE(sut.try_push(i));
    if (i % 3 != 0) {
      uint32_t v = 0;
      ASSERT_TRUE(sut.try_pop(v));
      ASSERT_EQ(v, next_out++);
    }
    while (sut.size_approx() > 6) ASSERT_EQ(sut.try_pop(), next_out++);
  }
  while (auto v = sut.try_pop()) EXPECT_EQ(*v, next_out++);
  EXPECT_EQ(next_out, 1000u);
  EXPECT_EQ(sut.dropped(), 0u);
}

struct Record {
  uint64_t seq = 0;
  std::array<uint64_t, 7> payload{};  // every word derived from seq: a torn copy shows
};

Record make_record(uint64_t seq) {
  Record r;
  r.seq = seq;
  for (std::size_t i = 0; i < r.payload.size(); ++i) r.payload[i] = seq * 2654435761u + i;
  return r;
}

bool intact(const Record& r) { return r.payload == make_record(r.seq).payload; }

// Two threads; the consumer checks that every value arrives whole, once and in order, and that
// values are lost only when the producer was told so (drops are counted, not silent).
TEST(SpscQueue, TwoThreadStressKeepsOrderAndIntegrity) {
  constexpr uint64_t kCount = 200'000;
  SpscQueue<Record, 64> sut;
  std::atomic<uint64_t> refused{0};

  std::thread producer([&] {
    for (uint64_t seq = 1; seq <= kCount; ++seq) {
      if (!sut.try_push(make_record(seq))) refused.fetch_add(1);
    }
  });
  uint64_t received = 0;
  uint64_t last_seq = 0;
  bool in_order = true;
  bool all_intact = true;
  for (;;) {
    Record r;
    if (sut.try_pop(r)) {
      ++received;
      in_order = in_order && r.seq > last_seq;
      all_intact = all_intact && intact(r);
      last_seq = r.seq;
      if (r.seq == kCount) break;
      continue;
    }
    // The last record may have been refused; stop once the producer is done and the queue empty.
    if (refused.load() + received == kCount && sut.size_approx() == 0) break;
  }
  producer.join();
  while (auto r = sut.try_pop()) {
    ++received;
    in_order = in_order && r->seq > last_seq;
    all_intact = all_intact && intact(*r);
    last_seq = r->seq;
  }

  EXPECT_TRUE(in_order);
  EXPECT_TRUE(all_intact);
  EXPECT_EQ(received + refused.load(), kCount);
  EXPECT_EQ(sut.dropped(), refused.load());
}

}  // namespace
}  // namespace doppel::concurrency
