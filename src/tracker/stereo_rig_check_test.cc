#include "ekf_vislam/tracker/stereo_rig_check.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ekf_vislam {
namespace {

TrackerFrameStats pair(int converged, int row_failed, int negative, float row_offset_px) {
  TrackerFrameStats stats;
  stats.stereo_converged = converged;
  stats.stereo_row_failed = row_failed;
  stats.stereo_negative_disparity = negative;
  stats.stereo_row_offset_px = row_offset_px;
  return stats;
}

TEST(StereoRigCheck, ARectifiedRigGivesNoHint) {
  StereoRigCheck check(1.0);
  for (int k = 0; k < 10; ++k) check.add(pair(300, 12, 3, 0.05f));
  EXPECT_EQ(check.matchesHeld(), 3000);
  EXPECT_NEAR(check.rowFailedFraction(), 0.04, 1e-12);
  EXPECT_NEAR(check.negativeDisparityFraction(), 30.0 / 2880.0, 1e-12);
  EXPECT_NEAR(check.medianRowOffsetPx(), 0.05, 1e-6);
  EXPECT_EQ(check.hint(), "");
}

TEST(StereoRigCheck, RowsApartAskWhetherTheImagesAreRectified) {
  StereoRigCheck check(1.0);
  for (int k = 0; k < 10; ++k) check.add(pair(300, 240, 0, k < 5 ? 3.0f : 3.2f));
  const std::string hint = check.hint();
  EXPECT_NE(hint.find("80 %"), std::string::npos) << hint;
  EXPECT_NE(hint.find("median row offset 3.2 px"), std::string::npos) << hint;
  EXPECT_NE(hint.find("rectified"), std::string::npos) << hint;
}

TEST(StereoRigCheck, NegativeDisparitiesAskWhetherTheImagesAreSwapped) {
  StereoRigCheck check(1.0);
  for (int k = 0; k < 10; ++k) check.add(pair(300, 20, 250, 0.0f));
  EXPECT_NEAR(check.negativeDisparityFraction(), 2500.0 / 2800.0, 1e-12);
  EXPECT_NE(check.hint().find("swapped"), std::string::npos) << check.hint();
}

TEST(StereoRigCheck, TooFewMatchesOrAResetGiveNoHint) {
  StereoRigCheck check(1.0);
  check.add(pair(StereoRigCheck::kMinMatches - 1, StereoRigCheck::kMinMatches - 1, 0, 5.0f));
  EXPECT_EQ(check.hint(), "");
  check.add(pair(1, 1, 0, 5.0f));
  EXPECT_NE(check.hint(), "");
  check.reset();
  EXPECT_EQ(check.matchesHeld(), 0);
  EXPECT_EQ(check.hint(), "");
  // A pair without any match has no row offset: the median leaves it out.
  check.add(pair(0, 0, 0, std::numeric_limits<float>::quiet_NaN()));
  EXPECT_EQ(check.medianRowOffsetPx(), 0.0);
}

TEST(StereoRigCheck, OnlyTheLastPairsCount) {
  StereoRigCheck check(1.0);
  for (int k = 0; k < StereoRigCheck::kWindowPairs; ++k) check.add(pair(300, 300, 0, 4.0f));
  EXPECT_NE(check.hint(), "");
  // A rig mended (a restart with the right images): the bad pairs leave the window.
  for (int k = 0; k < StereoRigCheck::kWindowPairs; ++k) check.add(pair(300, 3, 0, 0.0f));
  EXPECT_EQ(check.hint(), "");
  EXPECT_NEAR(check.rowFailedFraction(), 0.01, 1e-12);
}

TrackerFrameStats offsetPair(float offset_px, float sigma_px) {
  TrackerFrameStats stats = pair(300, 12, 3, 0.05f);
  stats.disparity_offset_px = offset_px;
  stats.disparity_offset_sigma_px = sigma_px;
  return stats;
}

TEST(StereoRigCheck, ADisparityOffsetAsksForTheRightCamerasCalibration) {
  StereoRigCheck check(1.0);
  check.add(offsetPair(-1.2f, 0.04f));
  check.add(offsetPair(-1.1f, 0.04f));
  EXPECT_EQ(check.hint(), "");  // too few pairs yet
  check.add(offsetPair(-1.3f, 0.04f));
  EXPECT_NEAR(check.medianDisparityOffsetPx(), -1.2, 1e-6);
  const std::string hint = check.hint();
  EXPECT_NE(hint.find("1.20 px below the true one (median over 3 pairs)"), std::string::npos)
      << hint;
  EXPECT_NE(hint.find("too large"), std::string::npos) << hint;
  EXPECT_NE(hint.find("estimate_disparity_offset"), std::string::npos) << hint;
}

TEST(StereoRigCheck, OffsetsWithinHalfAPixelOrNotToldApartGiveNoHint) {
  StereoRigCheck check(1.0);
  // An ordinary rig: 0.2-0.4 px.
  for (int k = 0; k < 20; ++k) check.add(offsetPair(-0.2f - 0.01f * k, 0.04f));
  EXPECT_EQ(check.hint(), "");
  // Pairs at rest: their fits tell nothing (large errors) and are left out.
  for (int k = 0; k < 20; ++k) check.add(offsetPair(-200.f, 80.f));
  EXPECT_EQ(check.disparityOffsetPairs(), 20);
  EXPECT_EQ(check.hint(), "");
  // A positive offset (depths too small) past the limit.
  for (int k = 0; k < 30; ++k) check.add(offsetPair(0.8f, 0.05f));
  EXPECT_NE(check.hint().find("0.80 px above"), std::string::npos) << check.hint();
  EXPECT_NE(check.hint().find("too small"), std::string::npos) << check.hint();
}

// Before kMinOffsetPairs fits, an offset counts only where it lies beyond half a pixel by two
// standard errors of the fits' median, their scatter taken as at least 0.15 px.
TEST(StereoRigCheck, FewFitsCountOnlyWellBeyondHalfAPixel) {
  // The KITTI 01 clip's first three fits: the correction starts at the third.
  StereoRigCheck clip(1.0, true);
  clip.add(offsetPair(-0.752f, 0.042f));
  clip.add(offsetPair(-0.868f, 0.039f));
  EXPECT_FALSE(clip.correcting());
  clip.add(offsetPair(-0.828f, 0.033f));
  EXPECT_TRUE(clip.correcting());
  EXPECT_NEAR(clip.disparityCorrectionPx(), -0.828, 1e-6);
  // 0.6 px, as steady as can be: 2 x 1.253 x 0.15 / sqrt(9) = 0.125 px > 0.1 px beyond, so the
  // tenth fit starts it.
  StereoRigCheck marginal(1.0, true);
  for (int k = 0; k < StereoRigCheck::kMinOffsetPairs - 1; ++k)
    marginal.add(offsetPair(-0.6f, 0.04f));
  EXPECT_FALSE(marginal.correcting());
  EXPECT_EQ(marginal.hint(), "");
  marginal.add(offsetPair(-0.6f, 0.04f));
  EXPECT_NEAR(marginal.disparityCorrectionPx(), -0.6, 1e-6);
  // Fits that scatter (median 0.9 px, deviations 0 / 0.7 / 0.7 px) wait for more.
  StereoRigCheck scattered(1.0, true);
  for (float offset_px : {-0.9f, -0.2f, -1.6f}) scattered.add(offsetPair(offset_px, 0.04f));
  EXPECT_FALSE(scattered.correcting());
  EXPECT_EQ(scattered.hint(), "");
}

// The correction the tracker applies (stereo/correct_disparity_offset): none within the hint's
// half pixel; beyond it the median, which it then follows, holding it where no pair is fitted.
TEST(StereoRigCheck, TheCorrectionStartsBeyondHalfAPixelAndThenFollowsTheMedian) {
  StereoRigCheck check(1.0, true);
  for (int k = 0; k < 30; ++k) check.add(offsetPair(-0.4f, 0.04f));
  EXPECT_EQ(check.disparityCorrectionPx(), 0.0);  // an ordinary rig
  for (int k = 0; k < 50; ++k) check.add(offsetPair(-1.2f, 0.04f));
  EXPECT_NEAR(check.disparityCorrectionPx(), -1.2, 1e-6);
  EXPECT_NE(check.hint().find("are corrected by it"), std::string::npos) << check.hint();
  // Back within half a pixel, it follows rather than switching off.
  for (int k = 0; k < 50; ++k) check.add(offsetPair(-0.45f, 0.04f));
  EXPECT_NEAR(check.disparityCorrectionPx(), -0.45, 1e-6);
  EXPECT_EQ(check.hint(), "");
  // A stop: no fit is told apart, the correction holds.
  for (int k = 0; k < 50; ++k) check.add(offsetPair(-200.f, 80.f));
  EXPECT_EQ(check.disparityOffsetPairs(), 0);
  EXPECT_NEAR(check.disparityCorrectionPx(), -0.45, 1e-6);
  check.reset();
  EXPECT_EQ(check.disparityCorrectionPx(), 0.0);
}

TrackerFrameStats rollPair(float roll_deg, float sigma_deg, float half_width_px = 620.f) {
  TrackerFrameStats stats = pair(300, 12, 3, 0.05f);
  stats.stereo_roll_deg = roll_deg;
  stats.stereo_roll_sigma_deg = sigma_deg;
  stats.stereo_roll_edge_px = static_cast<float>(roll_deg * M_PI / 180.0 * half_width_px);
  return stats;
}

TEST(StereoRigCheck, ARightImageTurnedAgainstTheLeftAsksForTheRectification) {
  StereoRigCheck check(1.0);
  // The KITTI 01 clip's roll (rows 0.51 px apart at the edge, of a 1 px tolerance): no hint.
  for (int k = 0; k < 20; ++k) check.add(rollPair(-0.046f, 0.003f));
  EXPECT_NEAR(check.medianStereoRollDeg(), -0.046, 1e-6);
  EXPECT_EQ(check.stereoRollPairs(), 20);
  EXPECT_EQ(check.hint(), "");
  // Turned 0.1 degrees clockwise: rows 1.08 px apart at the edge, beyond 0.75 px.
  for (int k = 0; k < StereoRigCheck::kWindowPairs; ++k) check.add(rollPair(0.1f, 0.003f));
  std::string hint = check.hint();
  EXPECT_NE(hint.find("turned 0.100 degrees clockwise"), std::string::npos) << hint;
  EXPECT_NE(hint.find("1.08 px apart"), std::string::npos) << hint;
  // The same angle on an image half as wide stays within the limit (0.54 px).
  StereoRigCheck narrow(1.0);
  for (int k = 0; k < 20; ++k) narrow.add(rollPair(0.1f, 0.003f, 310.f));
  EXPECT_EQ(narrow.hint(), "");
  // Anticlockwise; frames whose roll is not told (too few matches spread) are left out, and with
  // fewer than kMinRollPairs told there is no hint.
  StereoRigCheck other(1.0);
  for (int k = 0; k < 30; ++k) other.add(rollPair(-0.2f, 0.05f));
  for (int k = 0; k < StereoRigCheck::kMinRollPairs - 1; ++k) other.add(rollPair(-0.2f, 0.003f));
  EXPECT_EQ(other.stereoRollPairs(), StereoRigCheck::kMinRollPairs - 1);
  EXPECT_EQ(other.hint(), "");
  other.add(rollPair(-0.2f, 0.003f));
  EXPECT_NE(other.hint().find("0.200 degrees anticlockwise"), std::string::npos) << other.hint();
}

}  // namespace
}  // namespace ekf_vislam
