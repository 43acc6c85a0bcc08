// ros/rectify: a raw stereo pair rectified with its camera_info pair (K, D, R, P), before the
// tracker, for the node and track_stereo_bag alike. The rectified left camera is turned by the
// left camera_info's R from the camera's frame: the features are given in a frame of their own,
// "<frame>_rect", tied to the camera's frame by a static transform that the caller publishes
// (the node on /tf_static, track_stereo_bag into its bag).
#pragma once

#include "ekf_vislam/tracker/image_rectifier.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <std_msgs/Header.h>
#include <opencv2/core.hpp>

#include <optional>
#include <string>

namespace ekf_vislam {

/// The camera model of a camera_info's image (its size, distortion, K, R and P; binning and ROI
/// applied: ros_conversions::cameraInfoOfImage).
RawCameraModel rawCameraModel(const sensor_msgs::CameraInfo& info);

class StereoPairRectifier {
 public:
  enum class Result { kOk, kCameraInfoRefused, kSizeMismatch };

  /// Rectifies both 8-bit gray images in place, the maps made again when a camera_info changed,
  /// and makes *header's frame the rectified one (rectifiedFrame of its frame_id, or of the left
  /// camera_info's when empty). *new_transform is set to that frame's static transform when it is
  /// new (a first pair, another R or frame: to publish), else reset. Otherwise *why says what is
  /// wrong and nothing is changed. The camera_info pair has passed pairCalibration (gray_image.h),
  /// which refuses a binning or roi that gives no image.
  Result rectify(const sensor_msgs::CameraInfo& left_info,
                 const sensor_msgs::CameraInfo& right_info, cv::Mat* left, cv::Mat* right,
                 std_msgs::Header* header,
                 std::optional<geometry_msgs::TransformStamped>* new_transform, std::string* why);
  /// The rectified left camera's frame for the raw camera's `frame`.
  static std::string rectifiedFrame(const std::string& frame);
  double rectifyMsLast() const { return rectify_ms_last_; }

 private:
  /// The transform from `frame` (the raw left camera's) to rectifiedFrame(frame): the inverse of
  /// the left camera_info's R.
  geometry_msgs::TransformStamped leftTransform(const std::string& frame) const;

  ImageRectifier left_, right_;
  bool new_left_model_ = false;
  std::string rectified_from_frame_;  ///< the raw frame of the last transform given
  double rectify_ms_last_ = 0.0;
};

}  // namespace ekf_vislam
