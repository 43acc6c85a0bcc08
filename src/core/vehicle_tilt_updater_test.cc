#include "ekf_vislam/core/vehicle_tilt_updater.h"

#include "ekf_vislam/core/se3.h"
#include "testing/random_matrices.h"

#include <gtest/gtest.h>

#include <random>

namespace ekf_vislam {
namespace {

using testing::randomMatrix;

VislamOptions tiltOptions() {
  VislamOptions options;
  options.vehicle.tilt_sigma = 0.05;
  options.vehicle.body_tilt_sigma = 0.01;
  options.vehicle.tilt_update_period = 1.0;
  return options;
}

// Pose, gyro bias and road tilt (11 rows), optionally with a reported covariance.
FilterState tiltState(bool reported = false) {
  StateLayout layout;
  layout.bias_components = {3, 4, 5};
  layout.tilt_dim = 2;
  layout.reported_covariance = reported;
  FilterState state(layout);
  state.reset(StatePrior());
  return state;
}

double tiltAngle(const FilterState& state) {
  const Eigen::Vector3d up = se3::inverse(state.imu_T_world).block<3, 1>(0, 2);
  return std::acos(std::min(1.0, up.z()));
}

TEST(VehicleTiltUpdater, JacobianMatchesFiniteDifferences) {
  // h(R) = (R e3).head<2>() - s with R = exp(phi^) R_mean: dh/dphi = H_phi, and the residual is
  // -h (the observation is 0).
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0.4 * randomMatrix(3, 1, &rng)));
    const Eigen::Vector2d s = 0.05 * randomMatrix(2, 1, &rng);
    const TiltObservation obs = observeTilt(R, s);
    EXPECT_LT((obs.residual + ((R.col(2)).head<2>() - s)).norm(), 1e-15);
    const double h = 1e-6;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(j);
      const Eigen::Vector2d plus = -observeTilt(se3::expSO3(d) * R, s).residual;
      const Eigen::Vector2d minus = -observeTilt(se3::expSO3(-d) * R, s).residual;
      EXPECT_LT(((plus - minus) / (2 * h) - obs.H_phi.col(j)).norm(), 1e-8) << "column " << j;
    }
  }
  // A turn about the up axis (heading) does not change the tilt.
  const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0.05, -0.03, 1.2));
  EXPECT_LT((observeTilt(R, Eigen::Vector2d::Zero()).H_phi * R.col(2)).norm(), 1e-15);
}

TEST(VehicleTiltUpdater, UpdatesOncePerPeriodOfFilterTime) {
  const VislamOptions options = tiltOptions();
  VehicleTiltUpdater updater(options);
  FilterState state = tiltState();
  EXPECT_EQ(updater.update(10.0, &state), std::nullopt);  // the first call starts the period
  EXPECT_EQ(updater.update(10.5, &state), std::nullopt);
  EXPECT_EQ(updater.update(11.0, &state), UpdateStatus::kApplied);
  EXPECT_EQ(updater.update(11.9, &state), std::nullopt);
  EXPECT_EQ(updater.update(12.2, &state), UpdateStatus::kApplied);
  updater.reset();
  EXPECT_EQ(updater.update(20.0, &state), std::nullopt);
  EXPECT_EQ(updater.update(21.0, &state), UpdateStatus::kApplied);
}

TEST(VehicleTiltUpdater, DoesNothingWithoutTheRoadTiltInTheState) {
  const VislamOptions options = tiltOptions();
  VehicleTiltUpdater updater(options);
  StateLayout layout;
  FilterState state(layout);
  state.reset(StatePrior());
  state.imu_T_world = se3::exp((Vector6d() << 0, 0, 0, 0.1, 0, 0).finished());
  const Eigen::Matrix4d before = state.imu_T_world;
  EXPECT_EQ(updater.update(0.0, &state), std::nullopt);
  EXPECT_EQ(updater.update(5.0, &state), std::nullopt);
  EXPECT_EQ(state.imu_T_world, before);
}

TEST(VehicleTiltUpdater, AnUncertainTiltIsPulledToTheRoadAndAnUncertainRoadToTheVehicle) {
  const VislamOptions options = tiltOptions();
  const double tilt = 0.05;  // rad about world x
  for (const bool vehicle_uncertain : {true, false}) {
    FilterState state = tiltState();
    state.imu_T_world = se3::inverse(se3::exp((Vector6d() << 0, 0, 0, tilt, 0, 0).finished()));
    auto S = state.covariance();
    S.setZero();
    S.diagonal().setConstant(1e-10);
    const double vehicle_var = vehicle_uncertain ? 0.05 * 0.05 : 1e-8;
    const double road_var = vehicle_uncertain ? 1e-8 : 0.05 * 0.05;
    S.block<3, 3>(3, 3).diagonal().setConstant(vehicle_var);
    S.block<2, 2>(9, 9).diagonal().setConstant(road_var);
    S.block<3, 3>(6, 6).diagonal().setConstant(1e-4);  // gyro bias, uncorrelated
    VehicleTiltUpdater updater(options);
    updater.update(0.0, &state);
    ASSERT_EQ(updater.update(1.0, &state), UpdateStatus::kApplied);
    const Eigen::Vector3d up = se3::inverse(state.imu_T_world).block<3, 1>(0, 2);
    const double body_var = 0.01 * 0.01;
    if (vehicle_uncertain) {
      // Scalar Kalman update of the tilt: tilt (road + body) / (vehicle + road + body) remains.
      EXPECT_NEAR(tiltAngle(state),
                  tilt * (road_var + body_var) / (vehicle_var + road_var + body_var), 2e-4);
      EXPECT_NEAR(state.road_tilt_world.norm(), 0.0, 1e-5);
    } else {
      EXPECT_NEAR(tiltAngle(state), tilt, 1e-5);
      // The road takes the vehicle's tilt (up = (0, -sin tilt, cos tilt)), less the body's share.
      EXPECT_NEAR(state.road_tilt_world.y(), up.y() * road_var / (road_var + body_var), 2e-4);
      EXPECT_NEAR(state.road_tilt_world.x(), 0.0, 1e-9);
    }
    // Heading and position are not touched without cross-covariances; the bias stays.
    EXPECT_LT(state.bias.norm(), 1e-12);
    const Eigen::Vector3d p_world = se3::inverse(state.imu_T_world).topRightCorner<3, 1>();
    EXPECT_LT(p_world.norm(), 1e-12);
    EXPECT_LT(state.covariance()(3, 3), vehicle_var + 1e-12);
  }
}

TEST(VehicleTiltUpdater, TheReportedCovarianceTakesTheSameNoise) {
  // The body's tilt is no track error: with equal covariances before, both stay equal.
  const VislamOptions options = tiltOptions();
  FilterState state = tiltState(/*reported=*/true);
  std::mt19937 rng(5);
  const Eigen::MatrixXd A = randomMatrix(state.dim(), state.dim(), &rng);
  state.covariance(0) = 1e-3 * A * A.transpose();
  state.covariance(1) = state.covariance(0);
  const Vector6d pose = (Vector6d() << 1, 2, 0, 0.03, -0.02, 0.4).finished();
  state.imu_T_world = se3::inverse(se3::exp(pose));
  VehicleTiltUpdater updater(options);
  updater.update(0.0, &state);
  ASSERT_EQ(updater.update(1.0, &state), UpdateStatus::kApplied);
  EXPECT_LT((state.covariance(0) - state.covariance(1)).norm(), 1e-12);
  EXPECT_LT(state.covariance(0).trace(), (1e-3 * A * A.transpose()).trace());
}

}  // namespace
}  // namespace ekf_vislam
