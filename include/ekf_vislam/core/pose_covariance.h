// The pose covariance the estimator reports: the filter's pose error eps = [rho; phi] (world_T_imu
// = exp(eps^) world_T_imu_mean) turned into the world-axes errors [delta p; delta theta] that a
// user compares with a ground truth. To first order that is a linear map; where the rotation is
// uncertain by tens of degrees (dead reckoning over a long drive, with an unobservable gyro bias),
// the true positions spread along a curve the linear map flattens, and its covariance is thin in
// the one direction a rotation about the world's origin cannot move the position. The reported
// covariance adds the spread that a cubature over the exact map finds beyond the linear
// one, so it is never narrower than the linear covariance in any direction. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

namespace ekf_vislam {

/// M P M^T with M = [[I, -p^], [0, I]]: the first-order covariance of the world-axes errors
/// [delta p; delta theta] of a pose at `p_world` whose error eps = [rho; phi] has covariance P.
Matrix6d linearWorldPoseCovariance(const Matrix6d& eps_covariance, const Eigen::Vector3d& p_world);

/// The linear covariance plus the positive part of (S - linear), S the second moment about the
/// estimate of the exact errors [exp(phi) p + J_l(phi) rho - p; phi] over eps ~ N(0, P), taken by
/// a fifth-degree cubature rule (73 points). Where phi is small the map is nearly linear and this
/// is the linear covariance: the excess is of the order of sigma_phi^2 |p| in position (0.01 m for
/// 5 mrad at 400 m).
Matrix6d reportedWorldPoseCovariance(const Matrix6d& eps_covariance,
                                     const Eigen::Vector3d& p_world);

}  // namespace ekf_vislam
