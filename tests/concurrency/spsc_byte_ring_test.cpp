#include "concurrency/spsc_byte_ring.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <numeric>
#include <thread>
#include <vector>

namespace doppel::concurrency {
namespace {

using Bytes = std::vector<uint8_t>;

TEST(SpscByteRing, RecordsComeOutWholeAndInOrder) {
  SpscByteRing sut(64);
  ASSERT_TRUE(sut.try_write(Bytes{1, 2}, Bytes{3}));
  ASSERT_TRUE(sut.try_write(Bytes{}, Bytes{}));
  ASSERT_TRUE(sut.try_write(Bytes{9}));
  Bytes out;
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_EQ(out, (Bytes{1, 2, 3}));
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_TRUE(out.empty());
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_EQ(out, Bytes{9});
  EXPECT_FALSE(sut.try_read(out));
}

// Capacity counts the 4-byte length of each record: a record that does not fit is dropped whole
// and counted, and space comes back once the consumer has read.
TEST(SpscByteRing, AFullRingDropsWholeRecordsAndCountsThem) {
  SpscByteRing sut(64);
  const Bytes thirty(30, 0xAB);
  ASSERT_TRUE(sut.try_write(thirty));   // 34 bytes
  EXPECT_FALSE(sut.try_write(thirty));  // 68 > 64
  EXPECT_EQ(sut.dropped(), 1u);
  ASSERT_TRUE(sut.try_write(Bytes(26, 0x01)));  // exactly full
  Bytes out;
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_EQ(out, thirty);
  ASSERT_TRUE(sut.try_write(thirty));  // wraps around the end of the buffer
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_EQ(out, Bytes(26, 0x01));
  ASSERT_TRUE(sut.try_read(out));
  EXPECT_EQ(out, thirty);
}

TEST(SpscByteRing, TwoThreadsHandOverEveryRecordIntact) {
  SpscByteRing sut(1024);
  constexpr uint32_t kRecords = 20'000;
  std::thread producer([&] {
    for (uint32_t i = 0; i < kRecords;) {
      Bytes record(i % 50 + 4);
      std::iota(record.begin(), record.end(), static_cast<uint8_t>(i));
      std::memcpy(record.data(), &i, sizeof(i));
      if (sut.try_write(record)) ++i;
    }
  });
  uint32_t next = 0;
  Bytes out;
  while (next < kRecords) {
    if (!sut.try_read(out)) continue;
    ASSERT_EQ(out.size(), next % 50 + 4);
    uint32_t index = 0;
    std::memcpy(&index, out.data(), sizeof(index));
    ASSERT_EQ(index, next);
    for (std::size_t k = 4; k < out.size(); ++k) ASSERT_EQ(out[k], static_cast<uint8_t>(next + k));
    ++next;
  }
  producer.join();
}

}  // namespace
}  // namespace doppel::concurrency
