#include "ekf_vislam/core/track_correlation_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

// 200 tracks of 3-row residuals, each an AR(1) of correlation rho along its 15 frames.
TrackCorrelationEstimator estimateOn(double rho, int window, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  TrackCorrelationEstimator estimator(window, 100, 0.98);
  for (int track = 0; track < 200; ++track) {
    Eigen::VectorXd previous(3);
    for (int i = 0; i < 3; ++i) previous(i) = normal(*rng);
    for (int frame = 1; frame < 15; ++frame) {
      Eigen::VectorXd now(3);
      for (int i = 0; i < 3; ++i) {
        now(i) = rho * previous(i) + std::sqrt(1.0 - rho * rho) * normal(*rng);
      }
      estimator.add(now, previous);
      previous = now;
    }
  }
  return estimator;
}

TEST(TrackCorrelationEstimator, ReadsTheCorrelationOfAr1Tracks) {
  std::mt19937 rng(5);
  for (double rho : {0.0, 0.5, 0.85, 0.95}) {
    const TrackCorrelationEstimator estimator = estimateOn(rho, 100000, &rng);
    ASSERT_TRUE(estimator.ready());
    EXPECT_NEAR(estimator.correlation(), rho, 0.03) << rho;
    EXPECT_NEAR(estimator.varianceFactor(), (1.0 + rho) / (1.0 - rho),
                0.15 * (1.0 + rho) / (1.0 - rho))
        << rho;
  }
}

TEST(TrackCorrelationEstimator, ForgetsOldTracks) {
  std::mt19937 rng(6);
  std::normal_distribution<double> normal(0.0, 1.0);
  TrackCorrelationEstimator estimator(500, 100, 0.98);
  Eigen::VectorXd a(1), b(1);
  // Perfectly repeating tracks first, then white ones: the window follows the change.
  for (int k = 0; k < 2000; ++k) {
    a(0) = normal(rng);
    estimator.add(a, a);
  }
  EXPECT_DOUBLE_EQ(estimator.correlation(), 0.98);  // capped
  EXPECT_NEAR(estimator.varianceFactor(), 99.0, 1e-9);
  for (int k = 0; k < 5000; ++k) {
    a(0) = normal(rng);
    b(0) = normal(rng);
    estimator.add(a, b);
  }
  EXPECT_LT(estimator.correlation(), 0.1);
}

TEST(TrackCorrelationEstimator, IsOneUntilReadyAndIgnoresBadInput) {
  TrackCorrelationEstimator estimator(1000, 100, 0.98);
  Eigen::VectorXd a = Eigen::VectorXd::Ones(3);
  for (int k = 0; k < 99; ++k) estimator.add(a, a);
  EXPECT_FALSE(estimator.ready());
  EXPECT_EQ(estimator.varianceFactor(), 1.0);
  Eigen::VectorXd bad = a;
  bad(1) = std::nan("");
  estimator.add(bad, a);
  estimator.add(Eigen::VectorXd::Ones(2), a);
  EXPECT_EQ(estimator.pairs(), 99);
  estimator.add(a, a);
  EXPECT_TRUE(estimator.ready());
  EXPECT_DOUBLE_EQ(estimator.correlation(), 0.98);
  // Anti-correlated residuals read as white: no factor below 1.
  TrackCorrelationEstimator anti(1000, 100, 0.98);
  for (int k = 0; k < 200; ++k) anti.add(a, -a);
  EXPECT_EQ(anti.correlation(), 0.0);
  EXPECT_EQ(anti.varianceFactor(), 1.0);
}

}  // namespace
}  // namespace ekf_vislam
