// The stereo tracker's image input: which sensor_msgs/Image encodings it takes, each as the 8-bit
// gray image the tracker core works on, a sensor_msgs/CompressedImage made an Image, and the
// calibration a pair is tracked with. The nodelet and track_stereo_bag both go through these.
#pragma once

#include "ekf_vislam/core/types.h"
#include "ekf_vislam/tracker/deep_image_scale.h"

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <opencv2/core.hpp>

#include <string>

namespace ekf_vislam {

/// The encodings the tracker takes, for messages: "mono8, 8UC1, bgr8, ... or bayer_grbg8".
extern const char* const kTrackableEncodings;

/// Whether the tracker takes an image of this encoding: 8-bit gray (mono8, or 8UC1 as some
/// drivers call it), 8-bit colour (bgr8, rgb8, and the bgra8 / rgba8 of cameras such as the ZED)
/// or an 8-bit Bayer mosaic (bayer_rggb8, _bggr8, _gbrg8, _grbg8: a colour camera's raw image,
/// which Debian's image_proc cannot debayer), converted to gray; and the same at 16 bits (mono16,
/// 16UC1, bgr16, ..., bayer_grbg16), scaled to 8 (DeepImageScale).
bool isTrackableEncoding(const std::string& encoding);

/// The image as gray, 8-bit (16-bit for a 16-bit encoding: toGrayPair scales those): shared with
/// the message (no copy, valid while `msg` lives) for gray encodings, converted for colour ones.
/// False, with *why, for another encoding or data cv_bridge refuses.
bool toGrayImage(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why);

/// Both images of a pair as 8-bit gray (toGrayImage; 16-bit ones scaled to 8 by *scale, one scale
/// for the stream). False, with *why, when either cannot be converted.
bool toGrayPair(const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right,
                DeepImageScale* scale, cv::Mat* left_gray, cv::Mat* right_gray, std::string* why);

/// A CompressedImage (png, jpeg: cv::imdecode, as image_transport's compressed subscriber decodes
/// it, unchanged) as an Image under its header: mono8 (one 8-bit channel), bgr8, bgra8 or mono16
/// (a 16-bit png); another type gets a name the tracker refuses. Null, with *why, when the data
/// cannot be decoded.
sensor_msgs::ImagePtr decompressedImage(const sensor_msgs::CompressedImage& msg, std::string* why);

/// A compressed stereo pair decoded (decompressedImage), the right image on a second thread
/// beside the left; an image that does not decode is null, with its reason.
struct DecompressedPair {
  sensor_msgs::ImageConstPtr left, right;
  std::string why_left, why_right;
};
DecompressedPair decompressedPair(const sensor_msgs::CompressedImage& left,
                                  const sensor_msgs::CompressedImage& right);

/// Why pairCalibration refused a pair (a counter each, in the nodelet's diagnostics).
enum class PairCalibration { kOk, kCameraInfoRefused, kSizeMismatch };

/// The rectified calibration a pair whose left image is `left` is tracked with, from the
/// camera_info pair by the estimator's rule (ros_conversions::calibrationFromCameraInfo); the
/// camera_info's size (binning and roi applied), when it gives one, must be the image's. *stereo
/// is set only for kOk, *why otherwise.
PairCalibration pairCalibration(const sensor_msgs::CameraInfo& left_info,
                                const sensor_msgs::CameraInfo& right_info,
                                const sensor_msgs::Image& left, StereoCalibration* stereo,
                                std::string* why);

}  // namespace ekf_vislam
