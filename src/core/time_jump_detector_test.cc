#include "ekf_vislam/core/time_jump_detector.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

constexpr int kTwist = 0;
constexpr int kFeatures = 1;

TEST(TimeJumpDetector, OrderedStreamsAndSmallStepsBackAreNoJump) {
  TimeJumpDetector detector(1.0, 2);
  for (int k = 0; k < 100; ++k) {
    EXPECT_FALSE(detector.jumpedBack(kTwist, 100.0 + 0.01 * k));
    // Features lag the twist by 5 s: each stream is tested against itself.
    if (k % 10 == 0) {
      EXPECT_FALSE(detector.jumpedBack(kFeatures, 95.0 + 0.01 * k));
    }
  }
  // Out of order by less than the threshold (a late message): no jump.
  EXPECT_FALSE(detector.jumpedBack(kTwist, 100.0));
  EXPECT_DOUBLE_EQ(detector.lastJump(), 0.0);
}

TEST(TimeJumpDetector, BagPlayedAgainIsOneJump) {
  TimeJumpDetector detector(1.0, 2);
  for (int k = 0; k <= 300; ++k) {
    ASSERT_FALSE(detector.jumpedBack(kTwist, 100.0 + 0.1 * k));
    ASSERT_FALSE(detector.jumpedBack(kFeatures, 100.0 + 0.1 * k));
  }
  // The bag starts again at 100 s: the first stream to see it jumps, the other starts afresh.
  EXPECT_TRUE(detector.jumpedBack(kTwist, 100.0));
  EXPECT_DOUBLE_EQ(detector.lastJump(), 30.0);
  EXPECT_FALSE(detector.jumpedBack(kFeatures, 100.0));
  EXPECT_FALSE(detector.jumpedBack(kTwist, 100.1));
}

TEST(TimeJumpDetector, MessageInFlightFromBeforeTheJumpLeadsToASecondJump) {
  TimeJumpDetector detector(1.0, 2);
  EXPECT_FALSE(detector.jumpedBack(kTwist, 130.0));
  EXPECT_FALSE(detector.jumpedBack(kFeatures, 129.9));
  EXPECT_TRUE(detector.jumpedBack(kTwist, 100.0));
  EXPECT_FALSE(detector.jumpedBack(kFeatures, 130.0));  // still in flight: accepted
  EXPECT_TRUE(detector.jumpedBack(kFeatures, 100.1));   // the new time: starts once more
  EXPECT_NEAR(detector.lastJump(), 29.9, 1e-12);
  EXPECT_FALSE(detector.jumpedBack(kTwist, 100.2));
}

TEST(TimeJumpDetector, ZeroThresholdNeverJumps) {
  TimeJumpDetector detector(0.0, 2);
  EXPECT_FALSE(detector.jumpedBack(kTwist, 130.0));
  EXPECT_FALSE(detector.jumpedBack(kTwist, 0.0));
}

}  // namespace
}  // namespace ekf_vislam
