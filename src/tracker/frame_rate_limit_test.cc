#include "ekf_vislam/tracker/frame_rate_limit.h"

#include <gtest/gtest.h>

#include <random>

namespace ekf_vislam {
namespace {

// n stamps of a camera at `rate_hz` starting at `start`, each moved by up to +-jitter_s.
std::vector<double> cameraStamps(size_t n, double rate_hz, double start, double jitter_s) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-jitter_s, jitter_s);
  std::vector<double> stamps(n);
  for (size_t k = 0; k < n; ++k) stamps[k] = start + k / rate_hz + jitter(rng);
  return stamps;
}

std::vector<size_t> everyNth(size_t n, size_t step) {
  std::vector<size_t> indices;
  for (size_t k = 0; k < n; k += step) indices.push_back(k);
  return indices;
}

TEST(FrameRateLimit, ThinsAJitteryCameraToEveryNthPair) {
  // A 30 Hz camera with 3 ms of stamp jitter (a tenth of its period).
  const std::vector<double> stamps = cameraStamps(300, 30.0, 1000.0, 0.003);
  EXPECT_EQ(framesDueForTracking(stamps, 10.0), everyNth(300, 3));
  EXPECT_EQ(framesDueForTracking(stamps, 15.0), everyNth(300, 2));
  // At or above the camera's own rate, and without a limit, every pair.
  EXPECT_EQ(framesDueForTracking(stamps, 30.0), everyNth(300, 1));
  EXPECT_EQ(framesDueForTracking(stamps, 100.0), everyNth(300, 1));
  EXPECT_EQ(framesDueForTracking(stamps, 0.0), everyNth(300, 1));
}

TEST(FrameRateLimit, TakesTheFirstPairAndCountsFromTheLastTrackedOne) {
  EXPECT_TRUE(dueForTracking(5.0, -1.0, 10.0));  // nothing tracked yet
  EXPECT_FALSE(dueForTracking(5.07, 5.0, 10.0));
  EXPECT_TRUE(dueForTracking(5.08, 5.0, 10.0));  // past kRateSlack of the period
  EXPECT_TRUE(dueForTracking(5.001, 5.0, 0.0));
  // A gap (a dropped frame) restarts the count from the pair after it.
  const std::vector<double> stamps = {0.0, 0.1, 0.2, 0.5, 0.6, 0.7, 0.8};
  EXPECT_EQ(framesDueForTracking(stamps, 5.0), (std::vector<size_t>{0, 2, 3, 5}));
  EXPECT_TRUE(framesDueForTracking({}, 5.0).empty());
}

}  // namespace
}  // namespace ekf_vislam
