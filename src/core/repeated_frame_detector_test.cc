#include "ekf_vislam/core/repeated_frame_detector.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ekf_vislam {
namespace {

FeatureFrame frameOf(int first_id, int count, double shift) {
  FeatureFrame frame;
  for (int i = 0; i < count; ++i) {
    StereoObservation f;
    f.id = first_id + i;
    f.u_left = 100.0 + 7.0 * i + shift;
    f.v_left = f.v_right = 50.0 + 3.0 * i;
    f.u_right = f.u_left - 20.0;
    frame.features.push_back(f);
  }
  return frame;
}

TEST(RepeatedFrameDetector, IdenticalSharedTracksAreARepeat) {
  RepeatedFrameDetector detector;
  EXPECT_FALSE(detector.isRepeat(frameOf(0, 10, 0.0)));  // nothing to compare with
  EXPECT_FALSE(detector.isRepeat(frameOf(0, 10, 0.5)));  // moved
  // Same tracks, same coordinates, plus tracks that are new in this frame: still a repeat.
  FeatureFrame again = frameOf(0, 10, 0.5);
  const FeatureFrame extra = frameOf(100, 3, 0.0);
  again.features.insert(again.features.end(), extra.features.begin(), extra.features.end());
  std::vector<size_t> new_tracks;
  EXPECT_TRUE(detector.isRepeat(again, &new_tracks));
  EXPECT_EQ(new_tracks, (std::vector<size_t>{10, 11, 12}));  // the indices of ids 100-102
  EXPECT_FALSE(detector.isRepeat(frameOf(0, 10, 0.6), &new_tracks));
  EXPECT_TRUE(new_tracks.empty());  // ids 0-9 were all in the previous frame
}

TEST(RepeatedFrameDetector, HalfMovedOrTooFewSharedIsNotARepeat) {
  RepeatedFrameDetector detector(5);
  detector.isRepeat(frameOf(0, 10, 0.0));
  FeatureFrame half = frameOf(0, 10, 0.0);
  for (int i = 0; i < 5; ++i) half.features[2 * i].v_right += 1e-9;  // 5 of 10 moved
  EXPECT_FALSE(detector.isRepeat(half));
  detector.isRepeat(frameOf(0, 10, 0.0));
  EXPECT_FALSE(detector.isRepeat(frameOf(6, 10, 0.0 + 7.0 * 6)));  // 4 shared, all moved...
  detector.isRepeat(frameOf(0, 10, 0.0));
  EXPECT_FALSE(detector.isRepeat(frameOf(0, 4, 0.0)));  // 4 identical shared: below 5
  detector.isRepeat(frameOf(0, 10, 0.0));
  FeatureFrame nan = frameOf(0, 10, 0.0);
  for (int i = 0; i < 6; ++i) nan.features[i].u_left = std::nan("");
  detector.isRepeat(nan);
  EXPECT_FALSE(detector.isRepeat(nan));  // NaN never compares equal: 4 of 10 identical
  EXPECT_FALSE(detector.isRepeat(FeatureFrame{}));
}

TEST(RepeatedFrameDetector, AFewCorruptedFeaturesDoNotHideARepeat) {
  // A re-sent frame in which gross outliers replaced some features (or one is NaN): still a
  // repeat, as long as most shared tracks are bit-identical.
  RepeatedFrameDetector detector(5);
  detector.isRepeat(frameOf(0, 20, 0.0));
  FeatureFrame resent = frameOf(0, 20, 0.0);
  resent.features[3].u_left = 900.0;
  resent.features[3].u_right = 870.0;
  resent.features[11].v_left = std::nan("");
  EXPECT_TRUE(detector.isRepeat(resent));
  // 11 of 20 identical: a repeat; 10 of 20: not.
  detector.isRepeat(frameOf(0, 20, 0.0));
  FeatureFrame eleven = frameOf(0, 20, 0.0);
  for (int i = 0; i < 9; ++i) eleven.features[i].u_left += 0.25;
  EXPECT_TRUE(detector.isRepeat(eleven));
  detector.isRepeat(frameOf(0, 20, 0.0));
  FeatureFrame ten = frameOf(0, 20, 0.0);
  for (int i = 0; i < 10; ++i) ten.features[i].u_left += 0.25;
  EXPECT_FALSE(detector.isRepeat(ten));
}

}  // namespace
}  // namespace ekf_vislam
