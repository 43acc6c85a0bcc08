#include "ekf_vislam/core/stamp_gap_detector.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(StampGapDetector, CountsTheMessagesMissingFromAPeriodicStream) {
  StampGapDetector gaps;
  int missing = 0;
  // 10 Hz with 2 ms of jitter; frames 20-22 and 40 are missing.
  for (int k = 0; k < 60; ++k) {
    if ((k >= 20 && k <= 22) || k == 40) continue;
    missing += gaps.add(0.1 * k + ((k % 3) - 1) * 0.002);
    if (k == 23) {
      EXPECT_EQ(missing, 3);
    }
  }
  EXPECT_EQ(missing, 4);
  EXPECT_EQ(gaps.missing(), 4u);
  EXPECT_NEAR(gaps.period(), 0.1, 0.003);
}

TEST(StampGapDetector, KnowsNothingBeforeItsPeriodAndStartsAgainWhenTimeGoesBack) {
  StampGapDetector gaps;
  EXPECT_EQ(gaps.add(0.0), 0);
  EXPECT_EQ(gaps.add(1.0), 0);  // one interval: no period yet
  EXPECT_EQ(gaps.period(), 0.0);
  for (int k = 2; k <= 7; ++k) EXPECT_EQ(gaps.add(1.0 + 0.1 * (k - 1)), 0);
  EXPECT_NEAR(gaps.period(), 0.1, 1e-9);
  EXPECT_EQ(gaps.add(2.0), 3);  // 1.6 -> 2.0: three missing
  EXPECT_EQ(gaps.describeMissing(3, 2.0, "frame"),
            "about 3 frame(s) missing before 2.000 (period 0.100 s; 3 so far)");
  EXPECT_EQ(gaps.add(0.5), 0);  // back in time: a new estimate
  EXPECT_EQ(gaps.period(), 0.0);
  EXPECT_EQ(gaps.add(5.0), 0);
  EXPECT_EQ(gaps.missing(), 3u);  // kept through the new estimate
}

}  // namespace
}  // namespace ekf_vislam
