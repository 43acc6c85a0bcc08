#include "ekf_vislam/tracker/stereo_matcher.h"

#include "testing/blurred_texture.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace ekf_vislam {
namespace {

// A blurred random texture as the left image and, as the right one, the same texture moved by
// (dx, dy) px: a fronto-parallel wall at disparity -dx (dx < 0 for a rectified pair), its rows
// off by dy.
struct StereoPair {
  StereoPair(double dx, double dy) {
    left = testing::blurredTexture(cv::Size(400, 240), 11, 1.5);
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
    cv::warpAffine(left, right, shift, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    const cv::Size window(options.stereo_window_size, options.stereo_window_size);
    cv::buildOpticalFlowPyramid(left, left_pyramid, window, options.stereo_pyramid_levels, true);
    cv::buildOpticalFlowPyramid(right, right_pyramid, window, options.stereo_pyramid_levels, true);
  }
  TrackerOptions options;
  cv::Mat left, right;
  std::vector<cv::Mat> left_pyramid, right_pyramid;
};

// Points on a grid, away from the borders and the wall's edge in the right image.
std::vector<cv::Point2f> gridPoints() {
  std::vector<cv::Point2f> points;
  for (float v = 40; v <= 200; v += 32) {
    for (float u = 80; u <= 360; u += 28) points.emplace_back(u + 0.3f, v + 0.6f);
  }
  return points;
}

int count(const std::vector<uint8_t>& ok) {
  return static_cast<int>(std::count(ok.begin(), ok.end(), 1));
}

TEST(StereoMatcher, FindsTheDisparityFromZeroOrFromASeed) {
  const double disparity = 12.4;
  const StereoPair pair(-disparity, 0.0);
  const std::vector<cv::Point2f> left = gridPoints();
  for (const float seed : {0.0f, 12.0f}) {
    SCOPED_TRACE(seed);
    for (const bool refine : {false, true}) {
      std::vector<uint8_t> ok;
      StereoMatchCounts counts;
      const std::vector<cv::Point2f> right = matchStereo(
          pair.left_pyramid, pair.right_pyramid, left, std::vector<float>(left.size(), seed),
          pair.options, refine, cv::Mat(), &ok, &counts);
      ASSERT_EQ(right.size(), left.size());
      EXPECT_EQ(count(ok), static_cast<int>(left.size()));
      EXPECT_EQ(counts.matched, static_cast<int>(left.size()));
      EXPECT_EQ(counts.refined, refine ? static_cast<int>(left.size()) : 0);
      EXPECT_EQ(counts.converged(), static_cast<int>(left.size()));
      for (size_t i = 0; i < left.size(); ++i) {
        EXPECT_NEAR(left[i].x - right[i].x, disparity, 0.05) << i;
        EXPECT_NEAR(right[i].y, left[i].y, 0.05) << i;
      }
    }
  }
}

TEST(StereoMatcher, RefusesRowsApartAndNegativeDisparities) {
  const std::vector<cv::Point2f> left = gridPoints();
  const std::vector<float> no_seed(left.size(), 0.0f);
  {
    const StereoPair unrectified(-12.4, 2.5);  // rows 2.5 px apart, tolerance 1 px
    std::vector<uint8_t> ok;
    StereoMatchCounts counts;
    matchStereo(unrectified.left_pyramid, unrectified.right_pyramid, left, no_seed,
                unrectified.options, true, cv::Mat(), &ok, &counts);
    EXPECT_EQ(count(ok), 0);
    EXPECT_EQ(counts.row_failed, static_cast<int>(left.size()));
    ASSERT_EQ(counts.row_offsets.size(), left.size());
    for (const float offset : counts.row_offsets) EXPECT_NEAR(offset, 2.5, 0.05);
  }
  {
    const StereoPair swapped(6.0, 0.0);  // the right image's content right of the left one's
    std::vector<uint8_t> ok;
    StereoMatchCounts counts;
    matchStereo(swapped.left_pyramid, swapped.right_pyramid, left, no_seed, swapped.options, true,
                cv::Mat(), &ok, &counts);
    EXPECT_EQ(count(ok), 0);
    EXPECT_EQ(counts.disparity_failed, static_cast<int>(left.size()));
    EXPECT_EQ(counts.negative_disparity, static_cast<int>(left.size()));
  }
}

TEST(StereoMatcher, RefusesMatchesOnTheRightMask) {
  const StereoPair pair(-12.4, 0.0);
  const std::vector<cv::Point2f> left = gridPoints();
  cv::Mat right_mask(pair.right.size(), CV_8U, cv::Scalar(255));
  right_mask.colRange(0, 200).setTo(0);  // the robot's body in the right image's left part
  std::vector<uint8_t> ok;
  StereoMatchCounts counts;
  const std::vector<cv::Point2f> right = matchStereo(pair.left_pyramid, pair.right_pyramid, left,
                                                     std::vector<float>(left.size(), 0.0f),
                                                     pair.options, true, right_mask, &ok, &counts);
  int on_mask = 0;
  for (size_t i = 0; i < left.size(); ++i) {
    const bool masked = right[i].x < 200;
    on_mask += masked;
    EXPECT_EQ(ok[i], masked ? 0 : 1) << i;
  }
  EXPECT_GT(on_mask, 0);
  EXPECT_EQ(counts.masked, on_mask);
  EXPECT_EQ(counts.matched, static_cast<int>(left.size()));
}

}  // namespace
}  // namespace ekf_vislam
