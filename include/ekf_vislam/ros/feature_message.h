// The stereo tracker's output as a message: one StereoFeatureArray per tracked pair, written the
// same way by the nodelet (stereo/features) and by track_stereo_bag (the same topic in a bag).
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <ekf_vislam/StereoFeatureArray.h>
#include <std_msgs/Header.h>

#include <string>

namespace ekf_vislam {

/// What a pair without a single feature says (the nodelet's warning and track_stereo_bag's).
constexpr const char* kNoFeatureHint = "the images dark, flat, overexposed or covered?";

/// The features of `frame` (id, left and right pixel) under the left image's header; an empty
/// frame_id takes `fallback_frame` (the left camera_info's).
ekf_vislam::StereoFeatureArray featureMessage(const std_msgs::Header& left_header,
                                              const std::string& fallback_frame,
                                              const StereoFrame& frame);

}  // namespace ekf_vislam
