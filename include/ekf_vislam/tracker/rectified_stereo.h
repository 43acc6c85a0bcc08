// Pinhole projection and stereo triangulation of a rectified stereo pair (the fx, fy, cx, cy and
// baseline of a StereoCalibration): the formulas the tracker, its motion check and its quality
// measure share. Points are in the left camera frame (x right, y down, z forward, m); pixels in
// the rectified left image. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"
#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>

namespace ekf_vislam {

/// A rectified pair: both images share fx, fy, cx, cy; the right camera sits `baseline` metres
/// along the left camera's +x axis (disparity u_left - u_right = fx * baseline / z). No image
/// size, cam_T_imu the identity: all the tracker reads.
StereoCalibration rectifiedPair(double fx, double fy, double cx, double cy, double baseline);

/// True when a and b hold the same fx, fy, cx, cy and baseline (the tracker's whole view of a
/// calibration): a camera_info that changes any of them starts the tracker anew.
bool sameRectifiedPair(const StereoCalibration& a, const StereoCalibration& b);

/// The ray of a left-image pixel at unit depth: ((u - cx) / fx, (v - cy) / fy, 1).
Eigen::Vector3d normalized(const StereoCalibration& calibration, const cv::Point2f& pixel);

/// The point in the left camera frame seen at the left-image pixel `left` with the disparity
/// u_left - u_right (px): depth z = fx * baseline / disparity, then x and y from the pixel.
/// Empty when the disparity is not positive (or NaN).
std::optional<Eigen::Vector3d> triangulate(const StereoCalibration& calibration,
                                           const cv::Point2f& left, double disparity);

/// The left-image pixel (u, v) of a point p_cam in the left camera frame (z > 0), in double:
/// (fx * x / z + cx, fy * y / z + cy).
Eigen::Vector2d project(const StereoCalibration& calibration, const Eigen::Vector3d& p_cam);

/// The left camera's matrix K = [fx 0 cx; 0 fy cy; 0 0 1], for OpenCV's calib3d calls.
cv::Matx33d cameraMatrix(const StereoCalibration& calibration);

/// The disparity u_left - u_right (px) of a point at depth z (m): fx * baseline / z.
double disparityAtDepth(const StereoCalibration& calibration, double z);

}  // namespace ekf_vislam
