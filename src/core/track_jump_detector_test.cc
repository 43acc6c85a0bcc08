#include "ekf_vislam/core/track_jump_detector.h"

#include <gtest/gtest.h>

#include <random>

namespace ekf_vislam {
namespace {

// Checks built from a known common pose error, Gaussian flow noise and a few jumps.
std::vector<FlowCheck> makeChecks(int n, const Eigen::Matrix<double, 6, 1>& pose_error,
                                  double noise_px, const std::vector<int>& jumps, double jump_px,
                                  std::mt19937* rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<FlowCheck> checks(n);
  for (int i = 0; i < n; ++i) {
    FlowCheck& c = checks[i];
    // Jacobians of the size a camera gives (hundreds of px per rad, tens per m).
    for (int r = 0; r < 2; ++r) {
      for (int k = 0; k < 3; ++k) c.H_pose(r, k) = 30.0 * gauss(*rng);
      for (int k = 3; k < 6; ++k) c.H_pose(r, k) = 700.0 * gauss(*rng);
    }
    c.residual_change = c.H_pose * pose_error;
    c.residual_change += noise_px * Eigen::Vector2d(gauss(*rng), gauss(*rng));
  }
  for (int i : jumps) checks[i].residual_change(i % 2) += (i % 3 == 0 ? -jump_px : jump_px);
  return checks;
}

Eigen::Matrix<double, 6, 1> somePoseError() {
  Eigen::Matrix<double, 6, 1> e;
  e << 0.05, -0.03, 0.02, 0.004, -0.006, 0.003;  // m, rad: a twist-noise-sized prediction error
  return e;
}

TEST(TrackJumpDetector, FlagsJumpsAndOnlyJumps) {
  std::mt19937 rng(7);
  const std::vector<int> jumps = {3, 10, 17, 42, 55, 61, 80, 99};  // 8 %
  const auto checks = makeChecks(100, somePoseError(), 0.4, jumps, 4.0, &rng);
  const TrackJumpResult result = detectTrackJumps(checks, TrackJumpOptions{});
  ASSERT_TRUE(result.tested);
  for (int i = 0; i < 100; ++i) {
    const bool expected = std::find(jumps.begin(), jumps.end(), i) != jumps.end();
    EXPECT_EQ(result.jumped[i], expected) << "check " << i;
  }
  // The common pose error is recovered despite the jumps, and the scale is the noise's.
  // (noise 0.4 px over 200 rows: about 1e-3 m through 30 px/m, 3e-5 rad through 700 px/rad)
  const Eigen::Matrix<double, 6, 1> error = result.common_pose_error - somePoseError();
  EXPECT_LT(error.head<3>().norm(), 5e-3);
  EXPECT_LT(error.tail<3>().norm(), 2e-4);
  EXPECT_NEAR(result.sigma_px, 0.4, 0.1);
}

TEST(TrackJumpDetector, ThresholdFollowsTheNoise) {
  // White noise of 1.4 px (1 px per image, differenced): 3 px would flag 3 % of good tracks; the
  // robust 4-sigma bound keeps false alarms rare, while a 10 px jump is still found.
  std::mt19937 rng(3);
  const auto checks = makeChecks(200, somePoseError(), 1.4, {5, 50}, 10.0, &rng);
  const TrackJumpResult result = detectTrackJumps(checks, TrackJumpOptions{});
  ASSERT_TRUE(result.tested);
  int flagged = 0;
  for (bool j : result.jumped) flagged += j ? 1 : 0;
  EXPECT_TRUE(result.jumped[5]);
  EXPECT_TRUE(result.jumped[50]);
  EXPECT_LE(flagged, 3);
  EXPECT_NEAR(result.sigma_px, 1.4, 0.25);
}

TEST(TrackJumpDetector, LandmarkUncertaintyWidensTheBound) {
  std::mt19937 rng(11);
  auto checks = makeChecks(50, somePoseError(), 0.3, {}, 0.0, &rng);
  checks[7].residual_change(0) += 5.0;
  EXPECT_TRUE(detectTrackJumps(checks, TrackJumpOptions{}).jumped[7]);
  checks[7].landmark_variance = Eigen::Vector2d(4.0, 4.0);  // 2 px from its depth uncertainty
  EXPECT_FALSE(detectTrackJumps(checks, TrackJumpOptions{}).jumped[7]);
}

TEST(TrackJumpDetector, AFrameOfMostlyBadFlowIsLeftToTheGate) {
  // 40 % of the checks off by 10 px: not a few slid tracks but a bad frame; nothing flagged.
  std::mt19937 rng(9);
  std::vector<int> bad;
  for (int i = 0; i < 100; i += 5) bad.insert(bad.end(), {i, i + 1});
  const TrackJumpResult result =
      detectTrackJumps(makeChecks(100, somePoseError(), 0.4, bad, 10.0, &rng), TrackJumpOptions{});
  EXPECT_FALSE(result.tested);
  EXPECT_EQ(std::count(result.jumped.begin(), result.jumped.end(), true), 0);
}

TEST(TrackJumpDetector, TooFewChecksOrOffFlagsNothing) {
  std::mt19937 rng(5);
  const auto few = makeChecks(5, somePoseError(), 0.3, {1}, 20.0, &rng);
  const TrackJumpResult a = detectTrackJumps(few, TrackJumpOptions{});
  EXPECT_FALSE(a.tested);
  EXPECT_EQ(std::count(a.jumped.begin(), a.jumped.end(), true), 0);
  const auto many = makeChecks(40, somePoseError(), 0.3, {1}, 20.0, &rng);
  TrackJumpOptions off;
  off.threshold_px = 0.0;
  const TrackJumpResult b = detectTrackJumps(many, off);
  EXPECT_FALSE(b.tested);
  EXPECT_EQ(std::count(b.jumped.begin(), b.jumped.end(), true), 0);
}

}  // namespace
}  // namespace ekf_vislam
