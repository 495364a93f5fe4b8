#include "bus/wake_lead.h"

#include <gtest/gtest.h>

namespace doppel::bus {
namespace {

TEST(WakeLead, StartsWithoutLeadAndRisesHalfWayToALaterWakeUp) {
  WakeLead sut(300'000);
  EXPECT_EQ(sut.ns(), 0);

  sut.add(1'000'000, 1'100'000);  // 100 µs late
  EXPECT_EQ(sut.ns(), 50'000);
  sut.add(2'000'000, 2'100'000);
  EXPECT_EQ(sut.ns(), 75'000);
}

TEST(WakeLead, ConvergesOnASteadyLatenessAndOneStallDoesNotSetIt) {
  WakeLead sut(300'000);
  for (int i = 0; i < 40; ++i) sut.add(0, 60'000);
  EXPECT_NEAR(sut.ns(), 60'000, 1);

  sut.add(0, 260'000);  // one stall of 260 µs
  EXPECT_EQ(sut.ns(), 160'000);
  for (int i = 0; i < 60; ++i) sut.add(0, 60'000);
  EXPECT_LT(sut.ns(), 63'000);  // back near the steady lateness within a few dozen wake-ups
}

TEST(WakeLead, FallsByASixteenthOfTheGapPerEarlierWakeUpAndNeverBelowZero) {
  WakeLead sut(300'000);
  sut.add(0, 160'000);
  ASSERT_EQ(sut.ns(), 80'000);

  sut.add(0, 0);
  EXPECT_EQ(sut.ns(), 75'000);
  sut.add(500, 0);  // woke before the asked time: no lateness
  EXPECT_EQ(sut.ns(), 70'313);
  for (int i = 0; i < 1000; ++i) sut.add(0, 0);
  EXPECT_GE(sut.ns(), 0);
  EXPECT_LT(sut.ns(), 16);
}

TEST(WakeLead, IsBoundedByItsMaximum) {
  WakeLead sut(100'000);
  for (int i = 0; i < 100; ++i) sut.add(0, 5'000'000);  // a machine that wakes the thread 5 ms late
  EXPECT_EQ(sut.ns(), 100'000);

  WakeLead none(0);
  none.add(0, 80'000);
  EXPECT_EQ(none.ns(), 0);
}

}  // namespace
}  // namespace doppel::bus
