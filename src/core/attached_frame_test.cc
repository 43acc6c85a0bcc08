#include "ekf_vislam/core/attached_frame.h"

#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

Eigen::Isometry3d pose(double a, double b, double c, double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = se3::expSO3(Eigen::Vector3d(a, b, c));
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

/// The attached frame's [position; rotation] error (world axes) when the IMU pose has error
/// `imu_error` = [dp; dtheta]: p + dp, exp(dtheta^) R.
Vector6d frameErrorOf(const Vector6d& imu_error, const Eigen::Isometry3d& world_T_imu,
                      const Eigen::Isometry3d& imu_T_frame) {
  Eigen::Isometry3d perturbed = world_T_imu;
  perturbed.translation() += imu_error.head<3>();
  perturbed.linear() = se3::expSO3(imu_error.tail<3>()) * world_T_imu.linear();
  const Eigen::Isometry3d nominal = world_T_imu * imu_T_frame;
  const Eigen::Isometry3d moved = perturbed * imu_T_frame;
  Vector6d error;
  error << moved.translation() - nominal.translation(),
      se3::logSO3(moved.linear() * nominal.linear().transpose());
  return error;
}

TEST(AttachedFrame, PoseCovarianceFollowsTheFrameErrorAgainstFiniteDifferences) {
  const Eigen::Isometry3d world_T_imu = pose(0.1, -0.2, 1.3, 10.0, -4.0, 0.5);
  const Eigen::Isometry3d imu_T_frame = pose(0.0, 0.05, 3.1, -1.2, 0.1, -0.4);
  Matrix6d J;
  const double h = 1e-7;
  for (int i = 0; i < 6; ++i) {
    Vector6d e = Vector6d::Zero();
    e(i) = h;
    J.col(i) = frameErrorOf(e, world_T_imu, imu_T_frame) / h;
  }
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
  const Matrix6d covariance = a * a.transpose() * 1e-2;
  const AttachedFrameState out =
      moveToAttachedFrame(imu_T_frame, world_T_imu, covariance, TwistData(), Matrix6d::Zero());
  EXPECT_TRUE(out.world_T_frame.isApprox(world_T_imu * imu_T_frame));
  const Matrix6d expected = J * covariance * J.transpose();
  EXPECT_LT((out.pose_covariance_world - expected).norm(), 1e-5 * expected.norm());
}

TEST(AttachedFrame, TwistIsTheRigidBodyMotionOfTheFrameAgainstFiniteDifferences) {
  const Eigen::Isometry3d imu_T_frame = pose(0.2, -0.1, 2.0, -1.2, 0.3, -0.4);
  TwistData twist;
  twist.v_imu = Eigen::Vector3d(8.0, 0.1, -0.2);
  twist.w_imu = Eigen::Vector3d(0.05, -0.1, 0.4);
  Matrix6d twist_covariance = Matrix6d::Identity() * 1e-3;
  twist_covariance(0, 5) = twist_covariance(5, 0) = 2e-4;
  const AttachedFrameState out = moveToAttachedFrame(imu_T_frame, Eigen::Isometry3d::Identity(),
                                                     Matrix6d::Zero(), twist, twist_covariance);
  // The IMU moves by exp(h u^) in its own axes; the frame's own motion is
  // frame_T_imu exp(h u^) imu_T_frame = exp(h (Ad(frame_T_imu) u)^).
  auto frameTwist = [&](const Vector6d& u_imu) {
    const double h = 0.3;  // conjugating an exponential is exact: any step works
    const Eigen::Matrix4d delta =
        imu_T_frame.inverse().matrix() * se3::exp(h * u_imu) * imu_T_frame.matrix();
    return Vector6d(se3::log(delta) / h);
  };
  Vector6d u;
  u << twist.v_imu, twist.w_imu;
  const Vector6d expected = frameTwist(u);
  EXPECT_LT((out.twist.v_imu - expected.head<3>()).norm(), 1e-9);
  EXPECT_LT((out.twist.w_imu - expected.tail<3>()).norm(), 1e-9);
  // Linear map: its matrix by unit columns, then the covariance through it.
  Matrix6d J;
  for (int i = 0; i < 6; ++i) J.col(i) = frameTwist(Vector6d::Unit(i));
  const Matrix6d expected_covariance = J * twist_covariance * J.transpose();
  EXPECT_LT((out.twist_covariance - expected_covariance).norm(), 1e-9);
}

TEST(AttachedFrame, TheImuItselfIsUnchanged) {
  const Eigen::Isometry3d world_T_imu = pose(0.3, 0.2, -0.1, 1.0, 2.0, 3.0);
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
  const Matrix6d covariance = a * a.transpose();
  TwistData twist;
  twist.v_imu = Eigen::Vector3d(1, 2, 3);
  twist.w_imu = Eigen::Vector3d(0.1, 0.2, 0.3);
  const AttachedFrameState out = moveToAttachedFrame(Eigen::Isometry3d::Identity(), world_T_imu,
                                                     covariance, twist, covariance);
  EXPECT_TRUE(out.world_T_frame.isApprox(world_T_imu));
  EXPECT_LT((out.pose_covariance_world - covariance).norm(), 1e-12);
  EXPECT_LT((out.twist.v_imu - twist.v_imu).norm(), 1e-15);
  EXPECT_LT((out.twist_covariance - covariance).norm(), 1e-12);
}

}  // namespace
}  // namespace ekf_vislam
