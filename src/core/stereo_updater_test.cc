#include "ekf_vislam/core/stereo_updater.h"

#include "ekf_vislam/core/se3.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

// One landmark initialized at frame 0 (t = 0) from the pose then (which the clone keeps), seen
// again at frame 1 (t = 1.5 s) from a pose 1.2 m further on: the differenced observation's
// setting, with a calibration state and a track drift rate in the state too.
class DifferencedObservation : public ::testing::Test {
 protected:
  void SetUp() override {
    options_.noise.pixel_correlation = 0.8;
    layout_.disparity_dim = 1;  // a calibration column too
    layout_.drift_dim = 3;
    layout_.clone_dim = 6;
    state_ = FilterState(layout_);
    StatePrior prior;
    prior.position_sigma = prior.rotation_sigma = prior.disparity_offset_sigma = 0.1;
    prior.track_drift_rate_sigma = 1e-3;
    state_.reset(prior);
    state_.disparity_offset = 0.3;
    state_.track_drift_rate_imu = Eigen::Vector3d(2e-3, -1e-3, 5e-4);

    const Eigen::Matrix4d world_T_imu0 =
        se3::exp((Vector6d() << 0.1, 0.2, 0.05, 0.01, -0.02, 0.03).finished());
    state_.imu_T_world = se3::inverse(world_T_imu0);
    const Eigen::Vector3d p_world = (world_T_imu0 * Eigen::Vector4d(15.0, 2.0, 0.5, 1.0)).head<3>();
    Eigen::Vector4d z0;
    ASSERT_TRUE(camera_.project(state_.imu_T_world, p_world, &z0));
    StereoObservation f0{7, z0(0) + 0.4, z0(1) - 0.3, z0(2) + 0.2 - 0.3, z0(3) - 0.3};
    ASSERT_TRUE(landmarks_.initialize(f0, 0.0, LandmarkManager::kNewMapEntry, camera_, &state_,
                                      &stats_, &result_));
    state_.clonePose();

    landmarks_.beginFrame(kAge);
    const Eigen::Matrix4d world_T_imu1 =
        world_T_imu0 * se3::exp((Vector6d() << 1.2, 0.05, 0.01, 0.002, 0.001, 0.02).finished());
    state_.imu_T_world = se3::inverse(world_T_imu1);
    Eigen::Vector4d z1;
    ASSERT_TRUE(camera_.project(state_.imu_T_world, p_world, &z1));
    observation_ = StereoObservation{7, z1(0) - 0.6, z1(1) + 0.5, z1(2) - 0.6 - 0.3, z1(3) + 0.5};
  }

  StereoCandidate linearized(const FilterState& state) const {
    StereoCandidate c;
    c.feature = observation_;
    c.landmark = 0;
    EXPECT_TRUE(updater_.linearizeCandidate(camera_, state, landmarks_, &c));
    return c;
  }

  // The candidate's blocks placed in a dense rows x dim Jacobian.
  Eigen::MatrixXd denseJacobian(const StereoCandidate& c) const {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(c.residual.size(), state_.dim());
    H.leftCols<6>() = c.H_pose;
    if (c.clone_columns) H.middleCols<6>(layout_.cloneRow()) = c.H_clone;
    H.middleCols(layout_.calibrationRow(), layout_.calibrationDim()) = c.H_calibration;
    H.middleCols<3>(layout_.driftRow()) = c.H_drift;
    H.middleCols<3>(layout_.landmarkRow(0)) = c.H_landmark;
    return H;
  }

  static constexpr double kAge = 1.5;  ///< s, of the observation at frame 1
  VislamOptions options_;
  StateLayout layout_;
  FilterState state_{StateLayout()};
  StereoCamera camera_{testing::kittiLikeCalibration()};
  LandmarkManager landmarks_{options_};
  StereoUpdater updater_{options_};
  StereoObservation observation_;
  EstimatorStats stats_;
  FeedResult result_;
};

TEST_F(DifferencedObservation, JacobianMatchesCentralDifferencesOfTheStateError) {
  // residual(x (+) dx) = residual(x) - H dx to first order, with (+) the filter's own error
  // definitions (FilterState::applyCorrection): pose, clone, disparity offset, track drift rate
  // and landmark.
  const StereoCandidate c = linearized(state_);
  ASSERT_TRUE(c.differenced);
  ASSERT_TRUE(c.clone_columns);
  const Eigen::MatrixXd H = denseJacobian(c);
  const double eps = 1e-6;
  for (int i = 0; i < state_.dim(); ++i) {
    FilterState plus = state_, minus = state_;
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(state_.dim());
    dx(i) = eps;
    plus.applyCorrection(dx, true);
    minus.applyCorrection(-dx, true);
    const Eigen::VectorXd numeric =
        -(linearized(plus).residual - linearized(minus).residual) / (2.0 * eps);
    EXPECT_LT((numeric - H.col(i)).norm(), 1e-4 * std::max(1.0, H.col(i).norm())) << "column " << i;
  }
}

TEST_F(DifferencedObservation, ResidualIsTheWhitenedDifferenceWithThePreviousObservation) {
  const StereoCandidate c = linearized(state_);
  // The same candidate undifferenced, and the previous observation's residual from the clone.
  VislamOptions white = options_;
  white.noise.pixel_correlation = 0.0;
  const StereoUpdater plain(white);
  StereoCandidate now;
  now.feature = observation_;
  ASSERT_TRUE(plain.linearizeCandidate(camera_, state_, landmarks_, &now));
  EXPECT_FALSE(now.differenced);
  FilterState at_clone = state_;
  at_clone.imu_T_world = state_.imu_T_world_clone;
  at_clone.track_drift_rate_imu.setZero();  // the previous observation has age 0
  StereoCandidate before;
  const Eigen::Vector4d& z0 = landmarks_.track(0).previous_z;
  before.feature = StereoObservation{7, z0(0), z0(1), z0(2), z0(3)};
  ASSERT_TRUE(plain.linearizeCandidate(camera_, at_clone, landmarks_, &before));
  const double rho = 0.8;
  const Eigen::VectorXd expected =
      (now.residual - rho * before.residual) / std::sqrt(1 - rho * rho);
  EXPECT_LT((c.residual - expected).norm(), 1e-9);
  // The track-jump test keeps the observation's own residual.
  EXPECT_LT((c.flow_residual - now.residual.head<2>()).norm(), 1e-12);
}

TEST_F(DifferencedObservation, DriftRateExplainsATrackTurnedAwayFromItsPoint) {
  // The observation of frame 1 replaced by the exact projection of the landmark turned by
  // exp(kAge w^) about the IMU origin: at the true w the residual is second order in kAge w.
  VislamOptions white = options_;
  white.noise.pixel_correlation = 0.0;
  const StereoUpdater plain(white);
  const Eigen::Vector3d p_world = state_.landmark(0);
  const Eigen::Vector3d p_imu = (state_.imu_T_world * p_world.homogeneous()).head<3>();
  const Eigen::Vector3d turned = se3::expSO3(kAge * state_.track_drift_rate_imu) * p_imu;
  const Eigen::Vector3d p_cam = (camera_.camTImu() * turned.homogeneous()).head<3>();
  const Eigen::Vector4d z = camera_.Ks() * p_cam.homogeneous() / p_cam.z();
  StereoCandidate c;
  c.feature = StereoObservation{7, z(0), z(1), z(2) - state_.disparity_offset, z(3)};
  ASSERT_TRUE(plain.linearizeCandidate(camera_, state_, landmarks_, &c));
  EXPECT_NEAR(c.track_age, kAge, 1e-12);
  EXPECT_LT(c.residual.norm(), 0.02);  // px; the drift itself moves uL by about 2 px
  FilterState no_drift = state_;
  no_drift.track_drift_rate_imu.setZero();
  StereoCandidate without;
  without.feature = c.feature;
  ASSERT_TRUE(plain.linearizeCandidate(camera_, no_drift, landmarks_, &without));
  EXPECT_GT(without.residual.norm(), 1.0);
}

TEST_F(DifferencedObservation, OnlyAnObservationOfTheLastFrameIsDifferenced) {
  landmarks_.beginFrame(2 * kAge);  // a frame in which the track was not used
  EXPECT_FALSE(linearized(state_).differenced);
}

}  // namespace
}  // namespace ekf_vislam
