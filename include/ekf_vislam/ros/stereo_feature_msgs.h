// The generated ekf_vislam/StereoFeature(Array) messages, included so they can live next to the
// core's ekf_vislam::StereoFeature struct (core/types.h) in one translation unit.
//
// gencpp declares `typedef StereoFeature_<std::allocator<void>> ekf_vislam::StereoFeature`, which
// clashes with the core struct of the same name. Renaming the typedef while the generated headers
// are read avoids that: in ROS code the message element type is ekf_vislam::StereoFeatureMsg
// (the template StereoFeature_ and ekf_vislam::StereoFeatureArray keep their names). Include the
// messages through this header only, never <ekf_vislam/StereoFeature.h> directly.
#pragma once

#ifdef EKF_VISLAM_MESSAGE_STEREOFEATURE_H
#error "include ekf_vislam/ros/stereo_feature_msgs.h instead of <ekf_vislam/StereoFeature.h>"
#endif

#define StereoFeature StereoFeatureMsg
#include <ekf_vislam/StereoFeature.h>
#include <ekf_vislam/StereoFeatureArray.h>
#undef StereoFeature
