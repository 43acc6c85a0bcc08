#include "ekf_vislam/tracker/stereo_roll_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

const cv::Point2f kPrincipalPoint(607.0f, 185.0f);

struct Matches {
  std::vector<cv::Point2f> left;
  std::vector<float> row_offsets;
};

// n matches over a 1226x370 image whose rows differ by offset + roll (u - cx) + scale (v - cy),
// 0.3 px of noise (the KITTI clips' own), a fraction of them wrong by 2-20 px. `width` limits
// the columns to a band of that width about the principal point.
Matches makeMatches(double offset_px, double roll_rad, double scale, double wrong_fraction, int n,
                    uint32_t seed, double width = 1226.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  Matches matches;
  for (int i = 0; i < n; ++i) {
    const cv::Point2f left(static_cast<float>(kPrincipalPoint.x + width * (unit(rng) - 0.5)),
                           static_cast<float>(370 * unit(rng)));
    double row_offset = offset_px + roll_rad * (left.x - kPrincipalPoint.x) +
                        scale * (left.y - kPrincipalPoint.y) + noise(rng);
    if (unit(rng) < wrong_fraction) row_offset += (unit(rng) < 0.5 ? -1 : 1) * (2 + 18 * unit(rng));
    matches.left.push_back(left);
    matches.row_offsets.push_back(static_cast<float>(row_offset));
  }
  return matches;
}

constexpr double kDegree = M_PI / 180.0;

TEST(StereoRollFit, FindsTheRollOfARightImageTurnedAgainstTheLeft) {
  // Rolls of -0.3 to 0.3 degrees: at 0.3 the rows 600 px from the principal point lie 3.1 px
  // apart, beyond a 2 px window around the median row offset where the fit starts.
  for (const double roll_deg : {-0.3, -0.06, 0.0, 0.02, 0.3}) {
    for (const double offset_px : {0.0, 0.4}) {
      SCOPED_TRACE(testing::Message() << "roll " << roll_deg << " deg, offset " << offset_px);
      const Matches m = makeMatches(offset_px, roll_deg * kDegree, 1e-3, 0.2, 300, 7);
      const StereoRollFit fit = fitStereoRoll(m.left, m.row_offsets, kPrincipalPoint, 2.0);
      ASSERT_TRUE(fit.fitted);
      EXPECT_NEAR(fit.roll_rad / kDegree, roll_deg, 0.005);
      EXPECT_LT(std::abs(fit.roll_rad - roll_deg * kDegree), 4 * fit.roll_sigma_rad);
      EXPECT_LT(fit.roll_sigma_rad / kDegree, 0.005);
      EXPECT_NEAR(fit.row_offset_px, offset_px, 0.1);
      EXPECT_GT(fit.inliers, 0.75 * 300);
    }
  }
}

TEST(StereoRollFit, KeepsTheRowScaleApartFromTheRoll) {
  // Matches only in the image's lower right and upper left (columns and rows correlated): a
  // row scale alone must not read as a roll.
  Matches m = makeMatches(0.0, 0.0, 3e-3, 0.0, 400, 11);
  for (cv::Point2f& p : m.left) {
    if ((p.x > kPrincipalPoint.x) != (p.y > kPrincipalPoint.y)) p.y = 2 * kPrincipalPoint.y - p.y;
  }
  for (size_t i = 0; i < m.left.size(); ++i) {
    m.row_offsets[i] = static_cast<float>(3e-3 * (m.left[i].y - kPrincipalPoint.y));
  }
  const StereoRollFit fit = fitStereoRoll(m.left, m.row_offsets, kPrincipalPoint, 2.0);
  ASSERT_TRUE(fit.fitted);
  EXPECT_NEAR(fit.roll_rad / kDegree, 0.0, 1e-4);
}

TEST(StereoRollFit, NeedsEnoughMatchesSpreadOverTheColumns) {
  const Matches few = makeMatches(0.0, 0.001, 0.0, 0.0, kStereoRollMinMatches - 1, 3);
  EXPECT_FALSE(fitStereoRoll(few.left, few.row_offsets, kPrincipalPoint, 2.0).fitted);
  const Matches enough = makeMatches(0.0, 0.001, 0.0, 0.0, kStereoRollMinMatches + 20, 3);
  EXPECT_TRUE(fitStereoRoll(enough.left, enough.row_offsets, kPrincipalPoint, 2.0).fitted);
  // Every match within a 100 px wide band (column std 29 px): no slope to read.
  const Matches band = makeMatches(0.0, 0.001, 0.0, 0.0, 300, 3, 100.0);
  EXPECT_FALSE(fitStereoRoll(band.left, band.row_offsets, kPrincipalPoint, 2.0).fitted);
  // Every match wrong: nothing within the window of their median.
  Matches wrong = makeMatches(0.0, 0.0, 0.0, 0.0, 300, 3);
  for (size_t i = 0; i < wrong.row_offsets.size(); ++i)
    wrong.row_offsets[i] = (i % 2 ? 1 : -1) * 10.f * (1 + i % 7);
  EXPECT_FALSE(fitStereoRoll(wrong.left, wrong.row_offsets, kPrincipalPoint, 2.0).fitted);
}

}  // namespace
}  // namespace ekf_vislam
