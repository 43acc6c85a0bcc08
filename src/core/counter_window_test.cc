#include "ekf_vislam/core/counter_window.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(CounterWindow, ClosesOnceTheFirstCounterHasGrownEnough) {
  CounterWindow<2> window;
  EXPECT_FALSE(window.close({99, 7}, 100));
  const auto first = window.close({100, 8}, 100);
  ASSERT_TRUE(first);
  EXPECT_EQ(*first, (CounterWindow<2>::Counts{100, 8}));
  EXPECT_FALSE(window.close({150, 20}, 100));  // the next window starts at (100, 8)
  const auto second = window.close({230, 21}, 100);
  ASSERT_TRUE(second);
  EXPECT_EQ(*second, (CounterWindow<2>::Counts{130, 13}));
  // With no minimum every call closes a window (one per diagnostics period).
  const auto period = window.close({230, 25}, 0);
  ASSERT_TRUE(period);
  EXPECT_EQ(*period, (CounterWindow<2>::Counts{0, 4}));
}

}  // namespace
}  // namespace ekf_vislam
