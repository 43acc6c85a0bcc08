#include "ekf_vislam/core/repeated_frame_handler.h"

#include "ekf_vislam/core/se3.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

// (x, y, z, w), element by element (GCC 12 reports a false -Warray-bounds on Eigen's vectorized
// 3-to-4 copies).
Eigen::Vector4d withW(const Eigen::Vector3d& p, double w) { return {p.x(), p.y(), p.z(), w}; }

// A SLAM state with a pose clone: two landmarks seen in a repeated frame (held), then the pose
// moves on and the tracks through the repeated frame are shifted by the clone-to-now motion.
class RepeatedFrameShift : public ::testing::Test {
 protected:
  void SetUp() override {
    layout_.clone_dim = 6;
    state_ = FilterState(layout_);
    StatePrior prior;
    prior.position_sigma = 0.3;
    prior.rotation_sigma = 0.02;
    state_.reset(prior);
    const Eigen::Matrix4d world_T_imu_clone =
        se3::exp((Vector6d() << 2.0, -1.0, 0.1, 0.01, -0.02, 0.3).finished());
    state_.imu_T_world = se3::inverse(world_T_imu_clone);
    FeatureFrame frame;
    frame.stamp = 1.0;
    for (uint32_t id : {3u, 8u}) {
      const Eigen::Vector3d p_world =
          (world_T_imu_clone * Eigen::Vector4d(9.0 + 3 * id, 2.0 - 0.5 * id, 0.4, 1.0)).head<3>();
      Eigen::Vector4d z;
      ASSERT_TRUE(camera_.project(state_.imu_T_world, p_world, &z));
      const StereoObservation f{id, z(0), z(1), z(2), z(3)};
      ASSERT_TRUE(landmarks_.initialize(f, 1.0, LandmarkManager::kNewMapEntry, camera_, &state_,
                                        &stats_, &result_));
      frame.features.push_back(f);
    }
    handler_.hold(frame, {}, screening_, camera_, &state_, &landmarks_, &stats_, &result_);
    ASSERT_TRUE(handler_.pending());
    // The pose 1.1 m on with a turn, and a dense covariance over pose, clone and landmarks.
    state_.imu_T_world =
        se3::inverse(world_T_imu_clone *
                     se3::exp((Vector6d() << 1.1, 0.05, 0.0, 0.002, 0.001, 0.04).finished()));
    std::mt19937 rng(4);
    std::normal_distribution<double> normal(0.0, 0.05);
    Eigen::MatrixXd A(state_.dim(), state_.dim());
    for (int i = 0; i < A.size(); ++i) A(i) = normal(rng);
    state_.covariance() = A * A.transpose() + 1e-3 * Eigen::MatrixXd::Identity(A.rows(), A.cols());
  }

  // The landmark error after the shift, xi' = p'_true - exp(phi^) p'_mean, of landmark k when
  // the state's true values differ from its means by `error` (pose [rho; phi] left of
  // world_T_imu, clone the same, landmark p_true = exp(phi^) p_mean + xi), computed exactly.
  Eigen::Vector3d shiftedError(const Eigen::VectorXd& error, size_t k) const {
    const Vector6d pose_error = error.head<6>();
    const Vector6d clone_error = error.segment<6>(layout_.cloneRow());
    const Eigen::Vector3d xi = error.segment<3>(layout_.landmarkRow(k));
    const Eigen::Matrix4d world_T_imu = se3::inverse(state_.imu_T_world);
    const Eigen::Matrix4d world_T_clone = se3::inverse(state_.imu_T_world_clone);
    const Eigen::Matrix4d R_phi =
        se3::exp((Vector6d() << 0, 0, 0, pose_error.tail<3>()).finished());
    const Eigen::Vector4d p_mean = withW(state_.landmark(k), 1.0);
    const Eigen::Vector4d p_true = R_phi * p_mean + withW(xi, 0.0);
    const Eigen::Matrix4d delta = world_T_imu * se3::inverse(world_T_clone);
    const Eigen::Matrix4d delta_true =
        se3::exp(pose_error) * world_T_imu * se3::inverse(se3::exp(clone_error) * world_T_clone);
    return (delta_true * p_true - R_phi * (delta * p_mean)).head<3>();
  }

  VislamOptions options_;
  StateLayout layout_;
  FilterState state_{StateLayout()};
  StereoCamera camera_{testing::kittiLikeCalibration()};
  LandmarkManager landmarks_{options_};
  InputScreening screening_{options_};
  RepeatedFrameHandler handler_{options_};
  EstimatorStats stats_;
  FeedResult result_;
};

TEST_F(RepeatedFrameShift, MovesTheLandmarksAndTheirCovarianceThroughTheExactJacobian) {
  const int n = state_.dim();
  const Eigen::Matrix4d delta = se3::inverse(state_.imu_T_world) * state_.imu_T_world_clone;
  std::vector<Eigen::Vector3d> expected_means;
  for (size_t k = 0; k < 2; ++k) {
    expected_means.push_back((delta * withW(state_.landmark(k), 1.0)).head<3>());
  }
  // J: the identity except the moved landmarks' rows, by central differences of the exact
  // error map (the new error of every other variable is its old one).
  Eigen::MatrixXd J = Eigen::MatrixXd::Identity(n, n);
  const double h = 1e-6;
  for (size_t k = 0; k < 2; ++k) {
    const int row = layout_.landmarkRow(k);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
      e(j) = h;
      const Eigen::Vector3d column = (shiftedError(e, k) - shiftedError(-e, k)) / (2 * h);
      for (int i = 0; i < 3; ++i) J(row + i, j) = column(i);  // (see withW)
    }
  }
  const Eigen::MatrixXd before = state_.covariance();
  handler_.shiftCrossingTracks(camera_, &state_, &landmarks_, &stats_, &result_);
  EXPECT_FALSE(handler_.pending());
  EXPECT_EQ(stats_.get(Counter::kLandmarkShifted), 2u);

  Eigen::MatrixXd expected = J * before * J.transpose();
  const Eigen::Matrix4d world_T_imu = se3::inverse(state_.imu_T_world);
  const Eigen::Vector3d p_camera_world =
      (world_T_imu * camera_.imuTCam().col(3)).head<3>();  // the left camera's centre
  const double depth_var =
      options_.limits.repeated_frame_depth_sigma * options_.limits.repeated_frame_depth_sigma;
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_LT((state_.landmark(k) - expected_means[k]).norm(), 1e-9) << k;
    const Eigen::Vector3d ray = expected_means[k] - p_camera_world;
    expected.block<3, 3>(layout_.landmarkRow(k), layout_.landmarkRow(k)) +=
        depth_var * ray * ray.transpose();
  }
  const Eigen::MatrixXd after = state_.covariance();
  EXPECT_LT((after - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff())
      << "largest difference " << (after - expected).cwiseAbs().maxCoeff();
}

}  // namespace
}  // namespace ekf_vislam
