#include "ekf_vislam/core/attached_frame.h"

#include "ekf_vislam/core/se3.h"

namespace ekf_vislam {

TwistData moveTwist(const Matrix6d& adjoint_T_T_S, const TwistData& twist_S) {
  Vector6d u_S;
  u_S.head<3>() = twist_S.v_imu;
  u_S.tail<3>() = twist_S.w_imu;
  const Vector6d u_T = adjoint_T_T_S * u_S;
  TwistData twist_T = twist_S;
  twist_T.v_imu = u_T.head<3>();
  twist_T.w_imu = u_T.tail<3>();
  if (twist_S.hasCovariance()) {
    twist_T.covariance = adjoint_T_T_S * twist_S.covariance * adjoint_T_T_S.transpose();
  }
  return twist_T;
}

AttachedFrameState moveToAttachedFrame(const Eigen::Isometry3d& imu_T_frame,
                                       const Eigen::Isometry3d& world_T_imu,
                                       const Matrix6d& pose_covariance_world,
                                       const TwistData& twist_imu,
                                       const Matrix6d& twist_covariance) {
  AttachedFrameState out;
  out.world_T_frame = world_T_imu * imu_T_frame;

  Matrix6d pose_jacobian = Matrix6d::Identity();
  pose_jacobian.topRightCorner<3, 3>() =
      -se3::hat(Eigen::Vector3d(world_T_imu.linear() * imu_T_frame.translation()));
  out.pose_covariance_world = pose_jacobian * pose_covariance_world * pose_jacobian.transpose();

  const Matrix6d Ad = se3::adjoint(imu_T_frame.inverse().matrix());
  out.twist = moveTwist(Ad, twist_imu);
  out.twist_covariance = Ad * twist_covariance * Ad.transpose();
  return out;
}

}  // namespace ekf_vislam
