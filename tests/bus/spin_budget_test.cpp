#include "bus/spin_budget.h"

#include <gtest/gtest.h>

#include <unistd.h>

namespace doppel::bus {
namespace {

TEST(SpinBudget, GrantsNoMoreSlotsThanItHas) {
  SpinBudget sut(2);

  const bool first = sut.try_acquire();
  const bool second = sut.try_acquire();
  const bool third = sut.try_acquire();

  EXPECT_TRUE(first);
  EXPECT_TRUE(second);
  EXPECT_FALSE(third);
  EXPECT_FALSE(sut.has_free_slot());
}

TEST(SpinBudget, AReleasedSlotCanBeTakenAgain) {
  SpinBudget sut(1);
  ASSERT_TRUE(sut.try_acquire());

  sut.release();

  EXPECT_TRUE(sut.has_free_slot());
  EXPECT_TRUE(sut.try_acquire());
}

TEST(SpinBudget, ZeroOrNegativeSlotsMeansNobodySpins) {
  SpinBudget none(0);
  SpinBudget negative(-1);

  EXPECT_FALSE(none.try_acquire());
  EXPECT_FALSE(negative.try_acquire());
  EXPECT_EQ(negative.slots(), 0);
}

TEST(SpinBudget, ProcessBudgetLeavesOneCoreFree) {
  const long cpus = ::sysconf(_SC_NPROCESSORS_ONLN);

  EXPECT_EQ(SpinBudget::process().slots(), static_cast<int>(cpus) - 1);
}

}  // namespace
}  // namespace doppel::bus
