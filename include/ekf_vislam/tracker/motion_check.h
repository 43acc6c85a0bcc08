// Outlier rejection over frame-to-frame matches by RANSAC: PnP of the previous frame's stereo
// points against the current left image (the motion it finds is kept), or a fundamental matrix.
// No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_options.h"
#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace ekf_vislam {

struct MotionCheckResult {
  std::vector<uint8_t> inlier;  ///< per match; all 1 when the check did not run
  bool checked = false;         ///< RANSAC ran (enough matches)
  bool has_motion = false;      ///< PnP found the camera motion below
  Eigen::Matrix3d cur_R_prev = Eigen::Matrix3d::Identity();  ///< p_cur = R p_prev + t
  Eigen::Vector3d cur_t_prev = Eigen::Vector3d::Zero();
};

/// prev_points: each match's point in the previous left camera frame from its stereo depth
/// (z <= 0 when it has none); prev_pixels / cur_pixels: its left image positions.
MotionCheckResult checkTemporalMatches(const std::vector<cv::Point3f>& prev_points,
                                       const std::vector<cv::Point2f>& prev_pixels,
                                       const std::vector<cv::Point2f>& cur_pixels,
                                       const StereoCalibration& calibration,
                                       const TrackerOptions& options);

}  // namespace ekf_vislam
