#include "ekf_vislam/core/twist_at_rest.h"

#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

constexpr double kPeriod = 0.1;  // s between twist samples

VislamOptions restOptions() {
  VislamOptions options;
  options.noise.estimate_twist_noise = false;  // the configured densities: a known noise
  options.noise.angular_velocity_noise = 0.015;
  return options;
}

FilterState stateWithGyroBias(double gyro_prior_sigma) {
  StateLayout layout;
  layout.bias_components = {3, 4, 5};
  FilterState state(layout);
  StatePrior prior;
  prior.position_sigma = 0.01;
  prior.rotation_sigma = 0.01;
  prior.gyro_bias_sigma = gyro_prior_sigma;
  state.reset(prior);
  return state;
}

TwistData sampleAtRest(const Eigen::Vector3d& w_measured, double stamp) {
  TwistData twist;
  twist.stamp = stamp;
  twist.v_imu.setZero();
  twist.w_imu = w_measured;
  return twist;
}

TEST(GyroBiasAtRest, SamplesAtRestEstimateTheBiasAsTheConjugatePosteriorSays) {
  // Every sample reads the bias exactly: after n samples of variance s2 the estimate is the
  // prior's (0) and the samples' mean weighed by their information, its variance 1 / (1 / p2 +
  // n / s2), per axis.
  const VislamOptions options = restOptions();
  const Propagator propagator(options);
  const double p2 = 0.02 * 0.02;
  const double s2 = 0.015 * 0.015 / kPeriod;
  FilterState state = stateWithGyroBias(0.02);
  const Eigen::Vector3d bias(0.004, -0.007, 0.002);
  const int n = 50;
  for (int k = 0; k < n; ++k) {
    const std::optional<UpdateStatus> status =
        updateGyroBiasAtRest(propagator, sampleAtRest(bias, k * kPeriod), kPeriod, &state);
    ASSERT_TRUE(status.has_value());
    ASSERT_EQ(*status, UpdateStatus::kApplied);
  }
  const double variance = 1.0 / (1.0 / p2 + n / s2);
  EXPECT_LT((state.bias - bias * (variance * n / s2)).norm(), 1e-12);
  const Eigen::Matrix3d P_bias = state.covariance().block<3, 3>(6, 6);
  EXPECT_LT((P_bias - variance * Eigen::Matrix3d::Identity()).norm(), 1e-12 * variance * 1e3);
  // No rotation error correlated with the bias here: the pose stays.
  EXPECT_LT((state.imu_T_world - Eigen::Matrix4d::Identity()).norm(), 1e-15);
}

TEST(GyroBiasAtRest, TheRotationCorrelatedWithTheBiasFollowsIt) {
  // A second of driving at a constant rate leaves the heading's error correlated with the bias
  // (-1 s times it); at rest the bias is then measured, and the heading is corrected by the same
  // gain: its correction is -1 s times the bias's.
  const VislamOptions options = restOptions();
  const Propagator propagator(options);
  FilterState state = stateWithGyroBias(0.02);
  for (int k = 1; k <= 10; ++k) {
    propagator.predict(kPeriod, sampleAtRest(Eigen::Vector3d(0.0, 0.0, 0.1), k * kPeriod), 0.0,
                       &state);
  }
  const Eigen::Matrix4d before = state.imu_T_world;
  const Eigen::Vector3d bias(0.0, 0.0, 0.006);
  ASSERT_EQ(*updateGyroBiasAtRest(propagator, sampleAtRest(bias, 1.1), kPeriod, &state),
            UpdateStatus::kApplied);
  // The world-frame rotation error phi: T = exp(eps^) T_mean, so the correction's rotation is
  // log(T_before_world-to-imu ... ): read the heading change directly.
  const Eigen::Matrix3d R_before = se3::inverse(before).topLeftCorner<3, 3>();
  const Eigen::Matrix3d R_after = se3::inverse(state.imu_T_world).topLeftCorner<3, 3>();
  const Eigen::Vector3d turned = se3::logSO3(R_after * R_before.transpose());
  EXPECT_GT(state.bias.z(), 0.0);
  EXPECT_NEAR(turned.z(), -1.0 * state.bias.z(), 1e-6);
}

TEST(GyroBiasAtRest, NothingWithoutAGyroBiasOrNoise) {
  const VislamOptions options = restOptions();
  const Propagator propagator(options);
  StateLayout layout;  // no bias rows
  FilterState state(layout);
  state.reset(StatePrior{0.01, 0.01});
  EXPECT_FALSE(
      updateGyroBiasAtRest(propagator, sampleAtRest(Eigen::Vector3d::Ones(), 0.1), kPeriod, &state)
          .has_value());
  VislamOptions silent = restOptions();
  silent.noise.angular_velocity_noise = 0.0;
  const Propagator exact(silent);
  FilterState with_bias = stateWithGyroBias(0.02);
  EXPECT_FALSE(
      updateGyroBiasAtRest(exact, sampleAtRest(Eigen::Vector3d::Ones(), 0.1), kPeriod, &with_bias)
          .has_value());
}

}  // namespace
}  // namespace ekf_vislam
