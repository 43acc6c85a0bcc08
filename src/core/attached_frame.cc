#include "ekf_vislam/core/attached_frame.h"

#include "ekf_vislam/core/se3.h"

namespace ekf_vislam {

AttachedFrameState moveToAttachedFrame(const Eigen::Isometry3d& imu_T_frame,
                                       const Eigen::Isometry3d& world_T_imu,
                                       const Matrix6d& pose_covariance_world,
                                       const TwistData& twist_imu,
                                       const Matrix6d& twist_covariance) {
  const Eigen::Matrix3d R = imu_T_frame.linear();
  const Eigen::Vector3d t = imu_T_frame.translation();
  AttachedFrameState out;
  out.world_T_frame = world_T_imu * imu_T_frame;

  Matrix6d pose_jacobian = Matrix6d::Identity();
  pose_jacobian.topRightCorner<3, 3>() = -se3::hat(Eigen::Vector3d(world_T_imu.linear() * t));
  out.pose_covariance_world = pose_jacobian * pose_covariance_world * pose_jacobian.transpose();

  out.twist.stamp = twist_imu.stamp;
  out.twist.w_imu = R.transpose() * twist_imu.w_imu;
  out.twist.v_imu = R.transpose() * (twist_imu.v_imu + twist_imu.w_imu.cross(t));
  Matrix6d twist_jacobian = Matrix6d::Zero();
  twist_jacobian.topLeftCorner<3, 3>() = R.transpose();
  twist_jacobian.topRightCorner<3, 3>() = -R.transpose() * se3::hat(Eigen::Vector3d(t));
  twist_jacobian.bottomRightCorner<3, 3>() = R.transpose();
  out.twist_covariance = twist_jacobian * twist_covariance * twist_jacobian.transpose();
  if (twist_imu.hasCovariance()) {
    out.twist.covariance = twist_jacobian * twist_imu.covariance * twist_jacobian.transpose();
  }
  return out;
}

}  // namespace ekf_vislam
