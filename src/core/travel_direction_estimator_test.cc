#include "ekf_vislam/core/travel_direction_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

// A vehicle driving forwards and backwards at varying speed, seen in a twist frame mounted 1.2
// degrees of yaw and -0.7 degrees of pitch off its travel, with 0.3 m/s of white noise per axis.
TEST(TravelDirectionEstimator, RecoversTheMountingAngleOfANoisyTwist) {
  const double yaw = 1.2 * M_PI / 180.0, pitch = -0.7 * M_PI / 180.0;
  const Eigen::Vector3d direction(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                  std::sin(pitch));
  std::mt19937 generator(3);
  std::normal_distribution<double> noise(0.0, 0.3);
  TravelDirectionEstimator estimator(1.0);
  for (int k = 0; k < 3000; ++k) {
    const double speed = (k % 700 < 600 ? 1.0 : -0.4) * (4.0 + 6.0 * std::sin(0.01 * k));
    estimator.add(speed * direction +
                  Eigen::Vector3d(noise(generator), noise(generator), noise(generator)));
  }
  EXPECT_NEAR(estimator.yaw(), yaw, 0.2 * M_PI / 180.0);  // 4.5 standard errors
  EXPECT_NEAR(estimator.pitch(), pitch, 0.2 * M_PI / 180.0);
}

TEST(TravelDirectionEstimator, CountsOnlyMovingFiniteSamples) {
  TravelDirectionEstimator estimator(1.0);
  EXPECT_EQ(estimator.yaw(), 0.0);
  for (int k = 0; k < 10; ++k) estimator.add(Eigen::Vector3d(5.0, 0.5, 0.0));  // 5.7 degrees
  EXPECT_NEAR(estimator.yaw(), std::atan(0.1), 1e-12);
  EXPECT_EQ(estimator.pitch(), 0.0);
  // Standing still or not finite: not counted.
  estimator.add(Eigen::Vector3d(0.5, 0.4, 0.4));
  estimator.add(Eigen::Vector3d(NAN, 0.0, 0.0));
  EXPECT_EQ(estimator.samples(), 10u);
  EXPECT_NEAR(estimator.yaw(), std::atan(0.1), 1e-12);
  // Driving backwards shows the same mounting: the slope of y against x.
  for (int k = 0; k < 10; ++k) estimator.add(Eigen::Vector3d(-5.0, -0.5, 0.0));
  EXPECT_NEAR(estimator.yaw(), std::atan(0.1), 1e-12);
}

}  // namespace
}  // namespace ekf_vislam
