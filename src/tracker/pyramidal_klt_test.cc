#include "ekf_vislam/tracker/pyramidal_klt.h"

#include "testing/blurred_texture.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ekf_vislam {
namespace {

// The tracker's settings: 15x15 windows, 3 levels above the full image, 10 iterations to 0.03 px.
const KltSettings kTrackerKlt{
    cv::Size(15, 15), 3,
    cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 0.03)};

struct Comparison {
  int tracked_both = 0, tracked_cv_only = 0, tracked_ours_only = 0, lost_both = 0;
  std::vector<double> differences;  // px, where both tracked
  double quantile(double q) {
    std::sort(differences.begin(), differences.end());
    return differences[static_cast<size_t>(q * (differences.size() - 1))];
  }
};

// Tracks `points` from `first` into `second` (start points `start`) with OpenCV and with
// trackPyramidalKlt, and compares.
Comparison compare(const cv::Mat& first, const cv::Mat& second,
                   const std::vector<cv::Point2f>& points, const std::vector<cv::Point2f>& start,
                   const KltSettings& klt) {
  std::vector<cv::Mat> first_pyramid, second_pyramid;
  cv::buildOpticalFlowPyramid(first, first_pyramid, klt.window, klt.levels, true);
  cv::buildOpticalFlowPyramid(second, second_pyramid, klt.window, klt.levels, true);
#if defined(__AVX2__)
  EXPECT_TRUE(pyramidalKltFastPath(first_pyramid, second_pyramid, klt));
#endif
  std::vector<cv::Point2f> by_cv = start, ours = start;
  std::vector<uint8_t> cv_status, our_status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(first_pyramid, second_pyramid, points, by_cv, cv_status, error,
                           klt.window, klt.levels, klt.criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  trackPyramidalKlt(first_pyramid, second_pyramid, points, &ours, &our_status, klt);
  Comparison c;
  for (size_t i = 0; i < points.size(); ++i) {
    if (cv_status[i] && our_status[i]) {
      ++c.tracked_both;
      c.differences.push_back(cv::norm(by_cv[i] - ours[i]));
    } else if (cv_status[i]) {
      ++c.tracked_cv_only;
    } else if (our_status[i]) {
      ++c.tracked_ours_only;
    } else {
      ++c.lost_both;
    }
  }
  return c;
}

TEST(PyramidalKlt, TracksAsOpenCvDoesOverAMovingTexture) {
  // A blurred random texture, and the same texture turned, scaled, moved and made brighter; a
  // flat band where no point can be tracked; points everywhere, also at the borders.
  cv::Mat first = testing::blurredTexture(cv::Size(400, 300), 7, 1.2);
  first(cv::Rect(0, 140, 400, 20)).setTo(100);
  cv::Mat motion = cv::getRotationMatrix2D(cv::Point2f(200, 150), 2.0, 1.03);
  motion.at<double>(0, 2) += 6.3;
  motion.at<double>(1, 2) -= 3.7;
  cv::Mat second;
  cv::warpAffine(first, second, motion, first.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  second.convertTo(second, CV_8U, 1.1, 5);
  std::vector<cv::Point2f> points, start;
  cv::RNG rng(3);
  for (int i = 0; i < 2000; ++i) {
    const cv::Point2f p(rng.uniform(-3.f, 403.f), rng.uniform(-3.f, 303.f));
    points.push_back(p);
    start.emplace_back(p.x + rng.uniform(-2.f, 2.f) + 6.f, p.y + rng.uniform(-2.f, 2.f) - 4.f);
  }
  Comparison c = compare(first, second, points, start, kTrackerKlt);
  const double median = c.quantile(0.5), p95 = c.quantile(0.95);
  std::printf(
      "both %d, OpenCV only %d, ours only %d, neither %d; difference median %.5f, p95 "
      "%.5f, max %.5f px\n",
      c.tracked_both, c.tracked_cv_only, c.tracked_ours_only, c.lost_both, median, p95,
      c.differences.back());
  EXPECT_GT(c.lost_both, 50);  // the flat band and the points outside
  EXPECT_LE(c.tracked_cv_only + c.tracked_ours_only, 0.01 * c.tracked_both);
  EXPECT_LT(median, 1e-4);
  EXPECT_LT(p95, 1e-3);
  // Its strongest windows' sums pass 2^31 (summed in 32 bits, one point ends 0.0073 px apart).
  EXPECT_LT(c.differences.back(), 1e-3);
}

TEST(PyramidalKlt, TracksAsOpenCvDoesOverBlackAndWhiteBlocks) {
  // The largest derivatives and differences an 8-bit image has: their window sums pass 2^31.
  cv::Mat blocks(75, 100, CV_8UC1);
  cv::randu(blocks, 0, 2);
  blocks *= 255;
  cv::Mat first;
  cv::resize(blocks, first, cv::Size(400, 300), 0, 0, cv::INTER_NEAREST);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 2.5, 0, 1, 1.5);
  cv::Mat second;
  cv::warpAffine(first, second, shift, first.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  std::vector<cv::Point2f> points, start;
  cv::RNG rng(4);
  for (int i = 0; i < 1000; ++i) {
    points.emplace_back(rng.uniform(20.f, 380.f), rng.uniform(20.f, 280.f));
    start.push_back(points.back());
  }
  Comparison c = compare(first, second, points, start, kTrackerKlt);
  std::printf(
      "both %d, OpenCV only %d, ours only %d, neither %d; difference median %.5f, p95 "
      "%.5f px\n",
      c.tracked_both, c.tracked_cv_only, c.tracked_ours_only, c.lost_both, c.quantile(0.5),
      c.quantile(0.95));
  EXPECT_GT(c.tracked_both, 900);
  EXPECT_LE(c.tracked_cv_only + c.tracked_ours_only, 0.01 * c.tracked_both);
  EXPECT_LT(c.quantile(0.5), 1e-3);
  EXPECT_LT(c.quantile(0.95), 0.01);
}

TEST(PyramidalKlt, AWiderWindowOrAPyramidWithoutDerivativesFallsBackToOpenCv) {
  const cv::Mat image = testing::blurredTexture(cv::Size(200, 160), 2, 1.2);
  std::vector<cv::Mat> with, without;
  cv::buildOpticalFlowPyramid(image, with, cv::Size(21, 21), 2, true);
  cv::buildOpticalFlowPyramid(image, without, cv::Size(15, 15), 2, false);
  KltSettings wide = kTrackerKlt;
  wide.window = cv::Size(21, 21);
  EXPECT_FALSE(pyramidalKltFastPath(with, with, wide));
  EXPECT_FALSE(pyramidalKltFastPath(without, without, kTrackerKlt));
  std::vector<cv::Point2f> points = {{100, 80}}, next = {{101, 80}};
  std::vector<uint8_t> status;
  trackPyramidalKlt(with, with, points, &next, &status, wide);
  ASSERT_EQ(status.size(), 1u);
  EXPECT_EQ(status[0], 1);
  EXPECT_LT(cv::norm(next[0] - points[0]), 0.05);
}

}  // namespace
}  // namespace ekf_vislam
