#include "ekf_vislam/core/twist_noise_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

// A manoeuvring drive (speed and yaw rate vary smoothly, up to 2 m/s^2 and 0.3 rad/s^2) sampled
// at 10 Hz, with white noise of the given per-sample std on every component.
TwistData noisySample(int k, double sigma_v, double sigma_w, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const double t = 0.1 * k;
  TwistData twist;
  twist.stamp = t;
  twist.v_imu << 10.0 + 3.0 * std::sin(0.6 * t), 0.0, 0.0;
  twist.w_imu << 0.0, 0.0, 0.3 * std::sin(t);
  for (int i = 0; i < 3; ++i) {
    twist.v_imu(i) += sigma_v * normal(*rng);
    twist.w_imu(i) += sigma_w * normal(*rng);
  }
  return twist;
}

TEST(TwistNoiseEstimator, RecoversTheWhiteNoiseOfAManoeuvringDrive) {
  for (const auto& [sigma_v, sigma_w] : {std::pair{0.5, 0.05}, std::pair{0.05, 0.005}}) {
    std::mt19937 rng(3);
    TwistNoiseEstimator estimator(300, 20);
    for (int k = 0; k < 600; ++k) estimator.add(noisySample(k, sigma_v, sigma_w, &rng));
    ASSERT_TRUE(estimator.ready());
    EXPECT_NEAR(estimator.linearSigma(), sigma_v, 0.1 * sigma_v) << sigma_v;
    EXPECT_NEAR(estimator.angularSigma(), sigma_w, 0.1 * sigma_w) << sigma_w;
  }
}

TEST(TwistNoiseEstimator, ReadyAfterMinSamplesAndRobustToOutliers) {
  std::mt19937 rng(5);
  TwistNoiseEstimator estimator(300, 20);
  for (int k = 0; k < 22; ++k) {
    EXPECT_FALSE(estimator.ready()) << k;  // 20 second differences need 22 samples
    estimator.add(noisySample(k, 0.1, 0.01, &rng));
  }
  EXPECT_TRUE(estimator.ready());
  for (int k = 22; k < 400; ++k) {
    TwistData twist = noisySample(k, 0.1, 0.01, &rng);
    if (k % 20 == 0) twist.v_imu.x() += 30.0;  // 5 % gross outliers
    estimator.add(twist);
  }
  EXPECT_NEAR(estimator.linearSigma(), 0.1, 0.015);
}

TEST(TwistNoiseEstimator, AGapRestartsTheDifferences) {
  std::mt19937 rng(7);
  TwistNoiseEstimator estimator(300, 3);
  for (int k = 0; k < 10; ++k) estimator.add(noisySample(k, 0.0, 0.0, &rng));
  const double before = estimator.linearSigma();
  // Ten seconds later the speed is another: no difference spans the gap.
  TwistData after_gap = noisySample(110, 0.0, 0.0, &rng);
  after_gap.v_imu.x() += 50.0;
  estimator.add(after_gap);
  EXPECT_DOUBLE_EQ(estimator.linearSigma(), before);
  EXPECT_LT(before, 0.01);
}

}  // namespace
}  // namespace ekf_vislam
