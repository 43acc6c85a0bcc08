// Debug picture of a tracked stereo frame: left image above the right one; tracks drawn with
// their trails in the left image (colour by age), stereo matches in the right image as a line
// from the left position to the right one (the disparity as measured, without the rig's
// disparity correction); masked pixels (image_mask.h) dimmed.
// No ROS.
#pragma once

#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/tracker_types.h"

#include <opencv2/core.hpp>

namespace ekf_vislam {

/// left, right: 8-bit gray or BGR, same size. Returns a BGR image of twice the height, the zero
/// pixels of `masks` (those of the images' size) at a third of their brightness.
cv::Mat drawStereoTracks(const cv::Mat& left, const cv::Mat& right, const StereoFrame& frame,
                         const StereoMasks& masks = StereoMasks());

}  // namespace ekf_vislam
