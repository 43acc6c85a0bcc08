// The right image's roll against the left one, read from the rows of one frame's left-right
// matches. In a rectified pair a point lies on the same row in both images. A right camera
// turned about its optical axis against the rectification moves the rows apart in proportion to
// the column: v_right - v_left = offset + roll (u_left - cx). The median row offset does not
// show it (it is 0 at the principal point), but the matches near the side edges fail the row
// test, and the disparities err by roll (v - cy) at the top and bottom. The stereo rig check
// (stereo_rig_check.h) takes the median over many frames. No ROS.
#pragma once

#include <opencv2/core.hpp>

#include <limits>
#include <vector>

namespace ekf_vislam {

struct StereoRollFit {
  bool fitted = false;  ///< enough matches, spread over enough columns
  /// d(v_right - v_left) / d(u_left), rad: positive when the right image is turned clockwise as
  /// displayed (its points right of the principal point lie lower than the left image's).
  double roll_rad = 0;
  double roll_sigma_rad = std::numeric_limits<double>::infinity();  ///< its standard error
  double row_offset_px = 0;  ///< v_right - v_left at the principal point
  int inliers = 0;           ///< matches within the window of the fitted line
};

/// `left[i]`: a match's left pixel, `row_offsets[i]` its v_right - v_left (every match the KLT
/// ended inside the right image, wrong ones included). Starts from the median row offset and no
/// roll; then, until the chosen matches stay the same (at most a few rounds), chooses those
/// within `window_px` of the current fit and fits offset, roll and a row scale (v_right - v_left
/// growing with v_left - cy: unequal vertical focal lengths, kept apart from the roll) to them by
/// least squares. Needs kStereoRollMinMatches chosen matches whose columns spread
/// kStereoRollMinColumnSpreadPx (std).
StereoRollFit fitStereoRoll(const std::vector<cv::Point2f>& left,
                            const std::vector<float>& row_offsets,
                            const cv::Point2f& principal_point, double window_px);

constexpr int kStereoRollMinMatches = 30;
constexpr double kStereoRollMinColumnSpreadPx = 50.0;

}  // namespace ekf_vislam
