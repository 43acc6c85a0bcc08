// SO(3)/SE(3) utilities for the EKF: hat/vee, exp/log with small-angle branches, adjoint, the
// 6x6 curly hat, the SE(3) left Jacobian and the point operator odot. No ROS.
//
// Conventions: twist / perturbation xi = [rho; phi] (translation first, as u = [v; w]);
// hat(xi) = [[phi^, rho], [0, 0]] (4x4); curlyHat(xi) = [[phi^, rho^], [0, phi^]] (6x6).
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

namespace ekf_vislam {
namespace se3 {

Eigen::Matrix3d hat(const Eigen::Vector3d& w);
Eigen::Vector3d vee(const Eigen::Matrix3d& w_hat);
Eigen::Matrix4d hat(const Vector6d& xi);
Vector6d vee(const Eigen::Matrix4d& xi_hat);

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi);
/// Rotation vector of R, |phi| <= pi.
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);
/// Left Jacobian of SO(3).
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi);
Eigen::Matrix3d leftJacobianInverseSO3(const Eigen::Vector3d& phi);

Eigen::Matrix4d exp(const Vector6d& xi);
Vector6d log(const Eigen::Matrix4d& T);

/// Adjoint of T = [[R, p], [0, 1]]: [[R, p^ R], [0, R]], so T exp(xi^) T^-1 = exp((Ad(T) xi)^).
Matrix6d adjoint(const Eigen::Matrix4d& T);
/// [[phi^, rho^], [0, phi^]]; exp(curlyHat(xi)) = adjoint(exp(xi)).
Matrix6d curlyHat(const Vector6d& xi);
/// Left Jacobian of SE(3): exp((xi + d)^) = exp((J(xi) d)^) exp(xi^) + O(|d|^2).
Matrix6d leftJacobian(const Vector6d& xi);

/// [s; lambda]^odot = [[lambda I3, -s^], [0, 0]] (4x6), so xi^ s_h = s_h^odot xi.
Eigen::Matrix<double, 4, 6> odot(const Eigen::Vector4d& s_h);

/// Inverse of a rigid transform.
Eigen::Matrix4d inverse(const Eigen::Matrix4d& T);

/// Re-orthonormalizes the rotation block (keeps drift of repeated products in check).
void normalizeRotation(Eigen::Matrix4d* T);

}  // namespace se3
}  // namespace ekf_vislam
