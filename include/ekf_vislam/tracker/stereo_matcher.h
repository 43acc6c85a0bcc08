// Left-to-right matching in a rectified pair by pyramidal KLT seeded on the same row, checked
// by matching back right to left, by the row difference and by the disparity range. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_options.h"

#include <opencv2/core.hpp>

#include <vector>

namespace ekf_vislam {

/// Why left points found no right match (counts, added to over calls).
struct StereoMatchCounts {
  int klt_failed = 0;  ///< no convergence, or outside the right image
  int row_failed = 0;  ///< of the rest, rows further apart than stereo/row_tolerance_px
  int disparity_failed = 0;
  int negative_disparity = 0;  ///< of disparity_failed, the right point right of the left one
  int back_check_failed = 0;
  int matched = 0;
  int refined = 0;  ///< of the matched, aligned by refine/stereo
  int masked = 0;   ///< of the matched, refused on the right mask
  /// v_right - v_left of every KLT match inside the right image (before the checks), px, and
  /// the match's left pixel.
  std::vector<float> row_offsets;
  std::vector<cv::Point2f> row_offset_left;

  /// Matches the KLT ended inside the right image: those the row test was applied to.
  int converged() const { return row_failed + disparity_failed + back_check_failed + matched; }
};

/// Pyramids from cv::buildOpticalFlowPyramid (with derivatives) of the rectified left and right
/// images; `seed_disparity[i]` is the initial guess of u_left - u_right for left[i] (0 without
/// one). Returns the right points; ok[i] says whether left[i] was matched. With `refine`,
/// refine/enabled and refine/stereo, each match is then aligned: the left patch to the right image
/// (patch_refiner.h, WarpModel::kStereo); a refused alignment leaves the KLT match. Last, a match
/// on a zero pixel of `right_mask` (image_mask.h; empty: none) is refused.
std::vector<cv::Point2f> matchStereo(const std::vector<cv::Mat>& left_pyramid,
                                     const std::vector<cv::Mat>& right_pyramid,
                                     const std::vector<cv::Point2f>& left,
                                     const std::vector<float>& seed_disparity,
                                     const TrackerOptions& options, bool refine,
                                     const cv::Mat& right_mask, std::vector<uint8_t>* ok,
                                     StereoMatchCounts* counts);

}  // namespace ekf_vislam
