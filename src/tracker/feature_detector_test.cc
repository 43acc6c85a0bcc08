#include "ekf_vislam/tracker/feature_detector.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace ekf_vislam {
namespace {

// Many overlapping rectangles of random gray levels: corners everywhere.
cv::Mat rectangles(cv::Size size) {
  cv::Mat image(size, CV_8UC1, cv::Scalar(128));
  cv::RNG rng(11);
  for (int i = 0; i < 600; ++i) {
    const cv::Point corner(rng.uniform(-20, size.width), rng.uniform(-20, size.height));
    const cv::Size extent(rng.uniform(8, 40), rng.uniform(8, 40));
    cv::rectangle(image, cv::Rect(corner, extent), cv::Scalar(rng.uniform(0, 256)), -1);
  }
  return image;
}

class Detectors : public ::testing::TestWithParam<FeatureDetectorType> {};

TEST_P(Detectors, FillsCellsUpToTheCountAndKeepsTheDistance) {
  TrackerOptions options;
  options.detector = GetParam();
  options.grid_cols = 4;
  options.grid_rows = 2;
  options.max_features_per_cell = 4;
  options.min_feature_distance = 10;
  const cv::Mat image = rectangles(cv::Size(400, 200));
  GridFeatureDetector detector(options);
  // One cell (column 0, row 0) already holds 4 features: it gets none.
  std::vector<cv::Point2f> existing;
  for (int i = 0; i < 4; ++i) existing.emplace_back(20.f + 12 * i, 50.f);
  const std::vector<cv::Point2f> added = detector.detect(image, existing);
  std::vector<int> per_cell(8, 0);
  for (const cv::Point2f& p : added) {
    const int cell = detector.cellOf(p, image.size());
    ASSERT_GE(cell, 0);
    ++per_cell[cell];
    EXPECT_GE(p.x, options.border_px);
    EXPECT_GE(p.y, options.border_px);
    for (const cv::Point2f& q : existing) EXPECT_GE(cv::norm(p - q), 9.5);
    for (const cv::Point2f& q : added) {
      if (&p != &q) {
        EXPECT_GE(cv::norm(p - q), 9.5);
      }
    }
  }
  EXPECT_EQ(per_cell[0], 0);
  for (int cell = 1; cell < 8; ++cell) EXPECT_EQ(per_cell[cell], 4) << "cell " << cell;
}

INSTANTIATE_TEST_SUITE_P(FastAndShiTomasi, Detectors,
                         ::testing::Values(FeatureDetectorType::kFast,
                                           FeatureDetectorType::kShiTomasi));

TEST(GridFeatureDetector, NoCornerOnAMaskedPixel) {
  TrackerOptions options;
  const cv::Mat image = rectangles(cv::Size(400, 200));
  cv::Mat usable(image.size(), CV_8UC1, cv::Scalar(255));
  usable(cv::Rect(0, 120, 400, 80)).setTo(0);  // the bottom rows: a vehicle's hood
  GridFeatureDetector detector(options);
  const std::vector<cv::Point2f> everywhere = detector.detect(image, {});
  const std::vector<cv::Point2f> masked = detector.detect(image, {}, usable);
  ASSERT_GT(std::count_if(everywhere.begin(), everywhere.end(),
                          [](const cv::Point2f& p) { return p.y >= 120; }),
            20);
  ASSERT_GT(masked.size(), 20u);
  for (const cv::Point2f& p : masked) EXPECT_LT(cvRound(p.y), 120) << p;
}

// The corners searched beforehand (as the tracker does beside its tracking) give what detect()
// finds itself; Shi-Tomasi's search depends on the existing features, so it ignores them.
TEST_P(Detectors, CornersSearchedBeforehandGiveTheSameSelection) {
  TrackerOptions options;
  options.detector = GetParam();
  const cv::Mat image = rectangles(cv::Size(400, 200));
  GridFeatureDetector detector(options);
  std::vector<cv::Point2f> existing;
  for (int i = 0; i < 30; ++i) existing.emplace_back(10.f + 13 * i, 20.f + 5 * i);
  const std::vector<cv::KeyPoint> found = detector.independentCandidates(image);
  EXPECT_EQ(detector.candidatesIndependent(), GetParam() == FeatureDetectorType::kFast);
  EXPECT_EQ(found.empty(), !detector.candidatesIndependent());
  const std::vector<cv::Point2f> searched_now = detector.detect(image, existing);
  ASSERT_GT(searched_now.size(), 20u);
  EXPECT_EQ(detector.detect(image, existing, cv::Mat(), &found), searched_now);
  // Another image's corners would be taken as they are: they do reach the selection.
  if (detector.candidatesIndependent()) {
    const std::vector<cv::KeyPoint> other = detector.independentCandidates(image.t());
    EXPECT_NE(detector.detect(image, existing, cv::Mat(), &other), searched_now);
  }
}

TEST(GridFeatureDetector, FlatImageGivesNothing) {
  GridFeatureDetector detector{TrackerOptions()};
  EXPECT_TRUE(detector.detect(cv::Mat(200, 400, CV_8UC1, cv::Scalar(90)), {}).empty());
}

TEST(KeepApart, KeepsEarlierPointsAndEndsThoseTooNearThem) {
  const std::vector<cv::Point2f> points = {
      {100, 100},  // kept
      {105, 100},  // 5 px from the first: ended
      {110, 100},  // exactly 10 px from the first, 5 from the ended one: kept
      {50, 50},    // alone: kept
      {43, 43},    // 9.9 px from (50, 50), in the grid cell diagonally before it: ended
      {-3, -3},    // negative coordinates hash like the others: kept
      {-3, 4},     // 7 px from it: ended
  };
  const std::vector<uint8_t> keep = keepApart(points, 10.0);
  EXPECT_EQ(keep, (std::vector<uint8_t>{1, 0, 1, 1, 0, 1, 0}));
  EXPECT_EQ(keepApart(points, 0.0), std::vector<uint8_t>(points.size(), 1));
}

TEST(KeepApart, AgreesWithAllPairsOnRandomPoints) {
  cv::RNG rng(3);
  std::vector<cv::Point2f> points(800);
  for (cv::Point2f& p : points) p = cv::Point2f(rng.uniform(0.f, 400.f), rng.uniform(0.f, 200.f));
  const double min_distance = 7.5;
  const std::vector<uint8_t> keep = keepApart(points, min_distance);
  std::vector<cv::Point2f> kept;
  for (size_t i = 0; i < points.size(); ++i) {
    bool near_kept = false;
    for (const cv::Point2f& q : kept) near_kept |= cv::norm(points[i] - q) < min_distance;
    EXPECT_EQ(keep[i], near_kept ? 0 : 1) << i;
    if (!near_kept) kept.push_back(points[i]);
  }
  EXPECT_GT(kept.size(), 200u);
  EXPECT_LT(kept.size(), 700u);
}

}  // namespace
}  // namespace ekf_vislam
