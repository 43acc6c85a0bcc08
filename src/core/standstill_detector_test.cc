#include "ekf_vislam/core/standstill_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ekf_vislam {
namespace {

/// `count` tracks from first_id, each at a place of its id, moved by `shift` px along u (and
/// jittered by +-jitter, alternating, as a tracker at rest is).
FeatureFrame frameOf(int first_id, int count, double shift, double jitter = 0.0) {
  FeatureFrame frame;
  for (int i = 0; i < count; ++i) {
    StereoObservation f;
    f.id = first_id + i;
    f.u_left = 100.0 + 11.0 * (f.id % 100) + shift + (i % 2 == 0 ? jitter : -jitter);
    f.v_left = f.v_right = 50.0 + 3.0 * (f.id % 100);
    f.u_right = f.u_left - 20.0;
    frame.features.push_back(f);
  }
  return frame;
}

StandstillOptions options() {
  StandstillOptions o;
  o.max_displacement_px = 0.5;
  o.min_tracks = 10;
  return o;
}

TEST(StandstillDetector, TracksThatStayPutAreAtRestFromTheSecondFrame) {
  const StandstillOptions o = options();
  StandstillDetector detector(o);
  EXPECT_FALSE(detector.observe(frameOf(0, 20, 0.0)));  // nothing to compare with
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.0, 0.1)));
  EXPECT_TRUE(detector.atRest());
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.0, -0.2)));
  EXPECT_FALSE(detector.observe(frameOf(0, 20, 3.0)));  // drove off
  EXPECT_FALSE(detector.atRest());
}

TEST(StandstillDetector, ASlowCreepEndsTheRestOnceItAddsUpToTheBound) {
  const StandstillOptions o = options();
  StandstillDetector detector(o);
  detector.observe(frameOf(0, 20, 0.0));
  // 0.2 px per frame: each step is below the bound, the displacement since the rest began is
  // not for long: 0.2, 0.4 at rest, 0.6 not; then the next frame compares with that one.
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.2)));
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.4)));
  EXPECT_FALSE(detector.observe(frameOf(0, 20, 0.6)));
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.8)));
}

TEST(StandstillDetector, TooFewSharedTracksAreNotEvidence) {
  const StandstillOptions o = options();
  StandstillDetector detector(o);
  detector.observe(frameOf(0, 9, 0.0));
  EXPECT_FALSE(detector.observe(frameOf(0, 9, 0.0)));  // 9 < min_tracks
  detector.observe(frameOf(0, 20, 0.0));
  EXPECT_FALSE(detector.observe(frameOf(15, 20, 0.0)));  // 5 shared
}

TEST(StandstillDetector, TracksThatStartAtRestJoinTheReferenceWhereTheyStart) {
  const StandstillOptions o = options();
  StandstillDetector detector(o);
  detector.observe(frameOf(0, 12, 0.0));
  ASSERT_TRUE(detector.observe(frameOf(0, 12, 0.0)));
  // The first tracks end one after the other while new ones start (ids 100 on, at 0 px); by the
  // last frame none of the first is left, and the new ones still show the camera at rest.
  for (int k = 1; k <= 12; ++k) {
    FeatureFrame frame = frameOf(k, 12 - k, 0.0);
    const FeatureFrame fresh = frameOf(100, k, 0.0);
    frame.features.insert(frame.features.end(), fresh.features.begin(), fresh.features.end());
    EXPECT_TRUE(detector.observe(frame)) << "frame " << k;
  }
  EXPECT_FALSE(detector.observe(frameOf(100, 12, 1.0)));  // they move: the camera moved
}

TEST(StandstillDetector, NonFiniteTracksAndTheOptionsAreHonoured) {
  StandstillOptions o = options();
  StandstillDetector detector(o);
  detector.observe(frameOf(0, 20, 0.0));
  FeatureFrame corrupt = frameOf(0, 20, 0.0);
  for (int i = 0; i < 9; ++i) corrupt.features[i].u_left = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(detector.observe(corrupt));  // the 11 finite tracks decide
  o.enabled = false;
  EXPECT_FALSE(detector.observe(frameOf(0, 20, 0.0)));
  o.enabled = true;
  detector.reset();
  EXPECT_FALSE(detector.observe(frameOf(0, 20, 0.0)));  // no reference after a reset
  EXPECT_TRUE(detector.observe(frameOf(0, 20, 0.0)));
}

}  // namespace
}  // namespace ekf_vislam
