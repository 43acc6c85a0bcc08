#include "ekf_vislam/tracker/exposure_compensation.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <random>

namespace ekf_vislam {
namespace {

// A smooth random texture (values 40-200).
cv::Mat texture(int seed) {
  cv::Mat noise(240, 320, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 3.0);
  cv::normalize(noise, noise, 40, 200, cv::NORM_MINMAX);
  cv::Mat image;
  noise.convertTo(image, CV_8U);
  return image;
}

std::vector<cv::Point2f> grid(float dx) {
  std::vector<cv::Point2f> points;
  for (int v = 20; v < 220; v += 10) {
    for (int u = 20; u < 280; u += 10) points.emplace_back(u + dx, v);
  }
  return points;
}

TEST(ExposureCompensation, RecoversGainAndOffsetBetweenShiftedViews) {
  const cv::Mat from = texture(1);
  // `to` sees the scene 12 px to the left (a disparity), 1.3 times brighter, offset by -15.
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -12, 0, 1, 0);
  cv::warpAffine(from, shifted, shift, from.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const cv::Mat to = applyIntensityMap(shifted, IntensityMap{1.3, -15.0});
  const std::optional<IntensityMap> map = fitIntensityMap(from, grid(12), to, grid(0), 15, 20);
  ASSERT_TRUE(map);
  EXPECT_NEAR(map->gain, 1.3, 0.02);
  EXPECT_NEAR(map->offset, -15.0, 2.0);
  // The map applied brings `from` to `to`'s intensities (within the rounding to 8 bits).
  const cv::Mat mapped = applyIntensityMap(from, *map);
  cv::Mat difference;
  cv::absdiff(mapped(cv::Rect(12, 0, 300, 240)), to(cv::Rect(0, 0, 300, 240)), difference);
  EXPECT_LT(cv::mean(difference)[0], 1.5);
}

TEST(ExposureCompensation, PointsOffByAFewPixelsAndSomeWrongOnesStillServe) {
  const cv::Mat from = texture(2);
  const cv::Mat to = applyIntensityMap(from, IntensityMap{0.7, 20.0});
  std::vector<cv::Point2f> from_points = grid(0), to_points = grid(0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-2.f, 2.f);
  for (cv::Point2f& p : to_points) p += cv::Point2f(jitter(rng), jitter(rng));
  for (size_t i = 0; i < to_points.size(); i += 10) to_points[i] = cv::Point2f(150, 120);
  const std::optional<IntensityMap> map = fitIntensityMap(from, from_points, to, to_points, 15, 20);
  ASSERT_TRUE(map);
  EXPECT_NEAR(map->gain, 0.7, 0.05);
  EXPECT_NEAR(map->offset, 20.0, 3.0);
}

TEST(ExposureCompensation, NoMapWithoutEnoughPointsOrContrast) {
  const cv::Mat image = texture(4);
  const std::vector<cv::Point2f> all = grid(0);
  const std::vector<cv::Point2f> few(all.begin(), all.begin() + 5);
  EXPECT_FALSE(fitIntensityMap(image, few, image, few, 15, 20));
  // Points outside the image do not count.
  const std::vector<cv::Point2f> outside(50, cv::Point2f(-30, 500));
  EXPECT_FALSE(fitIntensityMap(image, outside, image, outside, 15, 20));
  const cv::Mat flat(240, 320, CV_8U, cv::Scalar(90));
  EXPECT_FALSE(fitIntensityMap(flat, grid(0), image, grid(0), 15, 20));
  // Enough textured points do give a map (the identity here).
  const std::optional<IntensityMap> map = fitIntensityMap(image, all, image, all, 15, 20);
  ASSERT_TRUE(map);
  EXPECT_EQ(map->gain, 1.0);
  EXPECT_EQ(map->offset, 0.0);
}

TEST(ExposureCompensation, MappedImagesSaturate) {
  const cv::Mat image(4, 4, CV_8U, cv::Scalar(200));
  EXPECT_EQ(applyIntensityMap(image, IntensityMap{1.5, 0.0}).at<uint8_t>(0, 0), 255);
  EXPECT_EQ(applyIntensityMap(image, IntensityMap{1.0, -250.0}).at<uint8_t>(0, 0), 0);
}

}  // namespace
}  // namespace ekf_vislam
