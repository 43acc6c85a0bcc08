// Frames rigidly attached to each other: a twist seen from another of them (moveTwist), and the
// estimator's outputs for a frame attached to the IMU (a robot's base_link): pose, pose
// covariance, twist and twist covariance moved through the fixed transform imu_T_frame. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Geometry>

namespace ekf_vislam {

struct AttachedFrameState {
  Eigen::Isometry3d world_T_frame = Eigen::Isometry3d::Identity();
  /// [position; rotation] errors in world axes, as VislamEstimator::poseCovarianceWorld.
  Matrix6d pose_covariance_world = Matrix6d::Zero();
  TwistData twist;  ///< the frame's own twist in its own axes (v_imu, w_imu hold the frame's)
  Matrix6d twist_covariance = Matrix6d::Zero();
};

/// A twist [v; w] of frame S (its origin's velocity, S axes) as the twist of a frame T rigidly
/// attached to it, with Ad = se3::adjoint(T_T_S), T_T_S = (R, p): v_T = R v_S + p x w_T,
/// w_T = R w_S; its covariance (when it has one) as Ad C Ad^T.
TwistData moveTwist(const Matrix6d& adjoint_T_T_S, const TwistData& twist_S);

/// world_T_frame = world_T_imu imu_T_frame; its position error is dp - (R_imu t) x dtheta and its
/// rotation error dtheta (world axes); its twist w = R^T w_imu, v = R^T (v_imu + w_imu x t) with
/// (R, t) = imu_T_frame. Covariances go through the same linear maps.
AttachedFrameState moveToAttachedFrame(const Eigen::Isometry3d& imu_T_frame,
                                       const Eigen::Isometry3d& world_T_imu,
                                       const Matrix6d& pose_covariance_world,
                                       const TwistData& twist_imu,
                                       const Matrix6d& twist_covariance);

}  // namespace ekf_vislam
