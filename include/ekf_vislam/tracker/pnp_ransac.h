// The camera motion between two frames from 3D-2D matches by RANSAC: minimal samples of three
// matches solved by P3P (OpenCV's AP3P, each of its up to four solutions scored), inliers counted
// by reprojection error; each better sample's motion refitted to its inliers (local optimization,
// LO-RANSAC), the number of samples adapted to the best inlier ratio found. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace ekf_vislam {

struct PnpRansacOptions {
  double threshold_px = 1.0;  ///< a match is an inlier within this reprojection error
  double confidence = 0.99;   ///< stop once a better motion is this unlikely to be missed
  int max_iterations = 200;   ///< samples at most
  uint32_t seed = 1;  ///< the samples are drawn from this seed: the same input, the same result
};

struct PnpRansacResult {
  bool found = false;  ///< a motion that explains at least 4 matches
  Eigen::Matrix3d cur_R_prev = Eigen::Matrix3d::Identity();  ///< p_cur = R p_prev + t
  Eigen::Vector3d cur_t_prev = Eigen::Vector3d::Zero();
  std::vector<int> inliers;  ///< indices of the matches the motion reprojects within the threshold
  int iterations = 0;        ///< samples drawn
};

/// points_prev: 3D points in the previous camera frame (z > 0); pixels_cur: where the current
/// (rectified, left) image sees them. At least 4 matches, else nothing is found.
PnpRansacResult pnpRansac(const std::vector<cv::Point3f>& points_prev,
                          const std::vector<cv::Point2f>& pixels_cur,
                          const StereoCalibration& calibration, const PnpRansacOptions& options);

/// d pixel / d (dtheta, dt) of a point q = R p + t (current camera frame, z > 0) under the motion
/// update R <- exp(dtheta) R, t <- exp(dtheta) t + dt: the Jacobian of the refit's Gauss-Newton.
Eigen::Matrix<double, 2, 6> reprojectionJacobian(const StereoCalibration& calibration,
                                                 const Eigen::Vector3d& q);

/// The number of samples that find an all-inlier one with `confidence`, for an inlier ratio and
/// a sample size, at most `max_iterations`.
int ransacIterationsNeeded(double inlier_ratio, int sample_size, double confidence,
                           int max_iterations);

}  // namespace ekf_vislam
