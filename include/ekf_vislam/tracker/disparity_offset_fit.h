// The stereo rig's disparity offset read from one pair of frames: the camera motion and one
// constant offset of every measured disparity fitted together to the tracks' frame-to-frame
// matches. A disparity offset (a rectification or right-camera calibration that disagrees with
// the images by a fraction of a pixel) scales near and far depths unequally, which no camera
// motion takes up, so a pair that moves forward sees it. The stereo rig check (stereo_rig_check.h)
// takes the median over many pairs. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <limits>
#include <vector>

namespace ekf_vislam {

struct DisparityOffsetFit {
  bool fitted = false;  ///< enough matches agreed with one motion and offset
  /// Measured minus true disparity (px), the convention of the estimator's
  /// intrinsic/estimate_disparity_offset: a negative offset makes every stereo depth too large.
  double offset_px = 0;
  /// Its standard error from this pair's matches (infinite when the motion cannot tell it apart,
  /// e.g. the camera at rest).
  double offset_sigma_px = std::numeric_limits<double>::infinity();
  int inliers = 0;  ///< matches within the threshold of the fitted motion and offset
  Eigen::Matrix3d cur_R_prev = Eigen::Matrix3d::Identity();  ///< p_cur = R p_prev + t
  Eigen::Vector3d cur_t_prev = Eigen::Vector3d::Zero();
};

/// One track between two frames: its previous left pixel and disparity (u_left - u_right), and
/// its current left pixel.
struct DisparityOffsetMatch {
  cv::Point2f prev_left;
  float prev_disparity = 0;
  cv::Point2f cur_left;
};

/// Starts from a motion (the RANSAC's, p_cur = R p_prev + t) and offset 0; then, until the
/// chosen matches stay the same (at most a few rounds): chooses the matches within
/// `threshold_px` of the current motion and offset, and fits the seven parameters to them by
/// Gauss-Newton. Choosing again after each fit keeps the result from leaning to 0: matches that
/// the offset alone put beyond the threshold come back once it is fitted.
DisparityOffsetFit fitDisparityOffset(const std::vector<DisparityOffsetMatch>& matches,
                                      const Eigen::Matrix3d& cur_R_prev,
                                      const Eigen::Vector3d& cur_t_prev,
                                      const StereoCalibration& calibration, double threshold_px);

}  // namespace ekf_vislam
