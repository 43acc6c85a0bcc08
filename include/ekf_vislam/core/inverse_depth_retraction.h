// How an EKF correction moves a landmark (landmarks/inverse_depth_correction). The update gives
// each landmark a first-order change; a Cartesian landmark moves along a straight line in world
// coordinates. A stereo observation z = [uL, v, uR] of a camera-frame point q is linear in the
// point's inverse-depth coordinates (a, b, r) = (x/z, y/z, 1/z):
//
//     uL = fx a + cx,   v = fy b + cy,   uR = fx a + cx - fx baseline r
//
// so moving the point along a straight line in (a, b, r) of the current camera makes the
// correction land where the linearized observation said, at any depth. The straight world line
// does not: a point whose disparity is known to a large fraction (far points) ends up too near,
// and many such corrections shorten the whole drive. Same first order, a different retraction;
// the covariance is unchanged. No ROS.
#pragma once

#include <Eigen/Core>

namespace ekf_vislam {
namespace inverse_depth_retraction {

/// The point q_cam (camera frame) moved by the first-order change dq_cam along a straight line
/// in its inverse-depth coordinates: q' with (a, b, r)(q') = (a, b, r)(q) + J dq, J the
/// Jacobian of (a, b, r) at q. Returns q + dq (the Cartesian move) when q lies closer than
/// min_depth in front of the camera or behind it, or when the move would take the inverse depth
/// below a fifth of its value (five times as far: the linearization no longer holds).
Eigen::Vector3d move(const Eigen::Vector3d& q_cam, const Eigen::Vector3d& dq_cam,
                     double min_depth = 1.0);

}  // namespace inverse_depth_retraction
}  // namespace ekf_vislam
