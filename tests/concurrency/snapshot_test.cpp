#include "concurrency/snapshot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <set>
#include <thread>
#include <vector>

namespace doppel::concurrency {
namespace {

TEST(Snapshot, ReaderSeesInitialValueUntilFirstPublish) {
  Snapshot<int> sut(7);

  EXPECT_EQ(sut.latest(), 7);
  EXPECT_FALSE(sut.update());
}

TEST(Snapshot, ReaderGetsNewestPublishedValue) {
  Snapshot<int> sut(0);

  sut.publish(1);
  sut.publish(2);
  sut.publish(3);

  int value = 0;
  EXPECT_TRUE(sut.read(value));
  EXPECT_EQ(value, 3);
  EXPECT_FALSE(sut.read(value));  // nothing newer
  EXPECT_EQ(value, 3);
}

TEST(Snapshot, InPlaceWriteThroughBack) {
  Snapshot<std::array<int, 3>> sut;

  sut.back() = {4, 5, 6};
  sut.publish();

  EXPECT_EQ(sut.latest(), (std::array<int, 3>{4, 5, 6}));
}

// A value that owns storage, filled in place: the three slots keep the storage the initial value
// gave them, so handing such values over never reallocates.
TEST(Snapshot, VectorsFilledInPlaceKeepTheirSlotsStorage) {
  Snapshot<std::vector<int>> sut(std::vector<int>(8, 0));
  std::set<const int*> storage;

  for (int round = 1; round <= 10; ++round) {
    std::vector<int>& back = sut.back();
    storage.insert(back.data());
    std::fill(back.begin(), back.end(), round);
    sut.publish();
    const std::vector<int>& seen = sut.latest();
    storage.insert(seen.data());

    EXPECT_EQ(seen, std::vector<int>(8, round));
  }
  EXPECT_EQ(storage.size(), 3u);
}

TEST(Snapshot, ReaderValueIsStableWhileWriterContinues) {
  Snapshot<int> sut(0);
  sut.publish(10);
  const int& held = sut.latest();

  sut.publish(11);
  sut.publish(12);
  sut.publish(13);

  EXPECT_EQ(held, 10);  // the writer never touches the reader's slot
  EXPECT_EQ(sut.latest(), 13);
}

struct Frame {
  uint64_t seq = 0;
  std::array<uint64_t, 31> words{};  // 256 bytes: copies take long enough to race
};

Frame make_frame(uint64_t seq) {
  Frame f;
  f.seq = seq;
  for (std::size_t i = 0; i < f.words.size(); ++i) f.words[i] = seq ^ (i * 0x9E3779B97F4A7C15u);
  return f;
}

// Writer and reader on two threads: every value the reader sees is whole (never a mix of two
// publishes) and sequence numbers never go backwards.
TEST(Snapshot, TwoThreadStressNeverTearsOrGoesBack) {
  constexpr uint64_t kCount = 300'000;
  Snapshot<Frame> sut(make_frame(0));
  std::atomic<bool> done{false};

  std::thread writer([&] {
    for (uint64_t seq = 1; seq <= kCount; ++seq) sut.publish(make_frame(seq));
    done.store(true, std::memory_order_release);
  });
  uint64_t last_seq = 0;
  uint64_t reads = 0;
  bool monotonic = true;
  bool whole = true;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    const Frame& f = sut.latest();
    ++reads;
    monotonic = monotonic && f.seq >= last_seq;
    whole = whole && f.words == make_frame(f.seq).words;
    last_seq = f.seq;
    if (finished && f.seq == kCount) break;
    ASSERT_FALSE(finished && f.seq != kCount) << "the last publish must be visible once the writer is done";
  }
  writer.join();

  EXPECT_TRUE(monotonic);
  EXPECT_TRUE(whole);
  EXPECT_EQ(last_seq, kCount);
  EXPECT_GT(reads, 1u);
}

}  // namespace
}  // namespace doppel::concurrency
