// Image masks of the stereo tracker: where in each rectified image features may lie. A robot
// whose own body, hood or mounting shows in the images masks it out, so that no feature sits on
// something that moves with the camera. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_options.h"

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace ekf_vislam {

/// 8-bit single-channel masks of the rectified left and right images: a nonzero pixel is usable,
/// a zero one is not. An empty mask: every pixel is usable.
struct StereoMasks {
  cv::Mat left;
  cv::Mat right;
};

/// Reads the images named by mask/left and mask/right ("" = no mask) as 8-bit gray masks (any
/// nonzero pixel usable). False, with *error naming the key and the file, when one cannot be read.
bool loadStereoMasks(const TrackerOptions& options, StereoMasks* masks, std::string* error);

/// Empty when each non-empty mask has the images' size, else what differs (naming its key).
std::string checkMaskSizes(const StereoMasks& masks, const cv::Size& image_size);

/// Whether `point` falls on a usable pixel of `mask` (its nearest pixel; outside the mask: no).
/// An empty mask: always.
bool usablePixel(const cv::Mat& mask, const cv::Point2f& point);

/// Clears ok[i] where points[i] is not on a usable pixel of `mask`; returns how many it cleared.
int refuseMaskedPoints(const cv::Mat& mask, const std::vector<cv::Point2f>& points,
                       std::vector<uint8_t>* ok);

}  // namespace ekf_vislam
