#include "ekf_vislam/core/velocity_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

TEST(VelocityReference, IsTheMeanOfTheSamplesBeforeTheLatest) {
  VelocityReference reference;
  const Eigen::Vector3d fallback(9.0, 9.0, 9.0);
  EXPECT_EQ(reference.value(fallback), fallback);
  reference.add(Eigen::Vector3d(1.0, 0.0, 0.0), 0.1);
  EXPECT_EQ(reference.value(fallback), fallback);  // only the latest sample so far
  reference.add(Eigen::Vector3d(3.0, 0.0, 0.0), 0.1);
  EXPECT_EQ(reference.value(fallback), Eigen::Vector3d(1.0, 0.0, 0.0));
  reference.add(Eigen::Vector3d(5.0, 0.0, 0.0), 0.1);
  // 0.9 x 1 + 0.1 x 3: the sample of 0.1 s weighs 0.1 / kTimeConstant.
  EXPECT_NEAR(reference.value(fallback).x(), 1.2, 1e-12);
  reference.add(Eigen::Vector3d(NAN, 0.0, 0.0), 0.1);  // left out
  EXPECT_NEAR(reference.value(fallback).x(), 1.2, 1e-12);
  reference.reset();
  EXPECT_EQ(reference.value(fallback), fallback);
}

TEST(VelocityReference, IsUncorrelatedWithTheLatestSamplesNoise) {
  // A constant speed measured with white noise as large as itself: the regression of the true
  // speed on the measured one is attenuated to speed^2 / (speed^2 + noise^2) = 0.5; on the
  // reference it is not.
  std::mt19937 generator(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  VelocityReference reference;
  double on_measured = 0.0, measured_squared = 0.0, on_reference = 0.0, reference_product = 0.0;
  for (int k = 0; k < 20000; ++k) {
    const double measured = 1.0 + noise(generator);
    reference.add(Eigen::Vector3d(measured, 0.0, 0.0), 0.1);
    const double ref = reference.value(Eigen::Vector3d(measured, 0.0, 0.0)).x();
    on_measured += 1.0 * measured;
    measured_squared += measured * measured;
    on_reference += 1.0 * ref;
    reference_product += measured * ref;
  }
  EXPECT_NEAR(on_measured / measured_squared, 0.5, 0.02);
  EXPECT_NEAR(on_reference / reference_product, 1.0, 0.03);
}

}  // namespace
}  // namespace ekf_vislam
