#include "ekf_vislam/tracker/stereo_rig_check.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace ekf_vislam
