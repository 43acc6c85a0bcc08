#include "ekf_vislam/core/restart_limiter.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(RestartLimiter, DropsATrackOnItsRestartBeyondTheLimit) {
  const int max_restarts = 2, max_track_gap = 1;
  RestartLimiter limiter(max_restarts, max_track_gap);
  EXPECT_FALSE(limiter.recordRestart(7));
  EXPECT_FALSE(limiter.recordRestart(7));
  EXPECT_FALSE(limiter.dropped(7));
  EXPECT_TRUE(limiter.recordRestart(7));  // the third: one too many
  EXPECT_TRUE(limiter.dropped(7));
  EXPECT_FALSE(limiter.recordRestart(7));  // already dropped: not dropped twice
  EXPECT_FALSE(limiter.dropped(8));
  EXPECT_EQ(limiter.droppedTracks(), 1u);
}

TEST(RestartLimiter, ADroppedTrackStaysDroppedUntilItEnds) {
  const int max_restarts = 1, max_track_gap = 2;
  RestartLimiter limiter(max_restarts, max_track_gap);
  limiter.recordRestart(3);
  ASSERT_TRUE(limiter.recordRestart(3));
  limiter.endFrame({3, 4}, false);
  limiter.endFrame({4}, false);  // absent 1
  limiter.endFrame({}, true);    // an empty message ends no track
  limiter.endFrame({4}, false);  // absent 2: within the gap
  EXPECT_TRUE(limiter.dropped(3));
  limiter.endFrame({3}, false);  // seen again: the gap starts over
  limiter.endFrame({4}, false);
  limiter.endFrame({4}, false);
  EXPECT_TRUE(limiter.dropped(3));
  limiter.endFrame({4}, false);  // absent 3 > max_track_gap: the track ended
  EXPECT_FALSE(limiter.dropped(3));
  EXPECT_FALSE(limiter.recordRestart(3));  // a new track under the old id counts from 0
}

TEST(RestartLimiter, RestartsOfATrackThatEndedAreForgotten) {
  const int max_restarts = 1, max_track_gap = 0;
  RestartLimiter limiter(max_restarts, max_track_gap);
  EXPECT_FALSE(limiter.recordRestart(5));
  limiter.endFrame({6}, false);
  EXPECT_FALSE(limiter.recordRestart(5));
}

TEST(RestartLimiter, ZeroMeansNoLimitAndResetForgetsAll) {
  int max_restarts = 0;
  const int max_track_gap = 3;
  RestartLimiter limiter(max_restarts, max_track_gap);
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(limiter.recordRestart(1));
  max_restarts = 1;  // the options are read when used
  limiter.reset();
  EXPECT_FALSE(limiter.recordRestart(1));
  EXPECT_TRUE(limiter.recordRestart(1));
  limiter.reset();
  EXPECT_FALSE(limiter.dropped(1));
  EXPECT_EQ(limiter.droppedTracks(), 0u);
}

}  // namespace
}  // namespace ekf_vislam
