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
    ASSERT_TRUE(estimator.linearReady() && estimator.angularReady());
    EXPECT_NEAR(estimator.linearSigma(), sigma_v, 0.1 * sigma_v) << sigma_v;
    EXPECT_NEAR(estimator.angularSigma(), sigma_w, 0.1 * sigma_w) << sigma_w;
  }
}

TEST(TwistNoiseEstimator, ReadyAfterMinSamplesAndRobustToOutliers) {
  std::mt19937 rng(5);
  TwistNoiseEstimator estimator(300, 20);
  for (int k = 0; k < 22; ++k) {
    EXPECT_FALSE(estimator.linearReady()) << k;  // 20 second differences need 22 samples
    EXPECT_FALSE(estimator.angularReady()) << k;
    estimator.add(noisySample(k, 0.1, 0.01, &rng));
  }
  EXPECT_TRUE(estimator.linearReady() && estimator.angularReady());
  for (int k = 22; k < 400; ++k) {
    TwistData twist = noisySample(k, 0.1, 0.01, &rng);
    if (k % 20 == 0) twist.v_imu.x() += 30.0;  // 5 % gross outliers
    estimator.add(twist);
  }
  EXPECT_NEAR(estimator.linearSigma(), 0.1, 0.015);
}

// A wheel odometry at rest reads exactly 0 while the gyro keeps its noise: 40 s of rest (more
// than the window) leave the linear estimate at the drive's, and a gyro-only stream gets an
// angular estimate without a linear one.
TEST(TwistNoiseEstimator, TheFirstDifferencesRejectOnlyAStdFarBelowTheirOwn) {
  // Over 40 starts of the manoeuvring drive (5 samples: 3 second differences, 9 squared values
  // per group), noise 0.1 m/s and 0.01 rad/s: the true std is rejected at 0.999 in at most 2 of
  // the 80 tests (0.08 expected from the noise; the manoeuvre adds a little), a quarter of it
  // in all of them.
  int rejected_true = 0, rejected_quarter = 0;
  for (int seed = 0; seed < 40; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    TwistNoiseEstimator estimator(300, 20);
    EXPECT_FALSE(estimator.angularExceeds(0.001, 0.999));  // nothing yet: nothing rejected
    for (int k = 0; k < 5; ++k) estimator.add(noisySample(k, 0.1, 0.01, &rng));
    ASSERT_FALSE(estimator.angularReady());
    rejected_true += estimator.linearExceeds(0.1, 0.999) + estimator.angularExceeds(0.01, 0.999);
    rejected_quarter +=
        estimator.linearExceeds(0.025, 0.999) + estimator.angularExceeds(0.0025, 0.999);
  }
  EXPECT_LE(rejected_true, 2);
  EXPECT_EQ(rejected_quarter, 80);
}

TEST(TwistNoiseEstimator, HeldValuesAtRestAreLeftOut) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  TwistNoiseEstimator estimator(300, 20);
  int k = 0;
  for (; k < 600; ++k) estimator.add(noisySample(k, 0.5, 0.05, &rng));
  for (; k < 1000; ++k) {
    TwistData at_rest;
    at_rest.stamp = 0.1 * k;
    at_rest.v_imu.setZero();
    for (int i = 0; i < 3; ++i) at_rest.w_imu(i) = 0.05 * normal(rng);
    estimator.add(at_rest);
  }
  EXPECT_NEAR(estimator.linearSigma(), 0.5, 0.05);
  EXPECT_NEAR(estimator.angularSigma(), 0.05, 0.005);

  TwistNoiseEstimator gyro_only(300, 20);
  for (k = 0; k < 100; ++k) {
    TwistData sample = noisySample(k, 0.0, 0.05, &rng);
    sample.v_imu.setZero();
    gyro_only.add(sample);
  }
  EXPECT_TRUE(gyro_only.angularReady());
  EXPECT_FALSE(gyro_only.linearReady());
  EXPECT_NEAR(gyro_only.angularSigma(), 0.05, 0.01);
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
