// Rectification of a raw (distorted, unrotated) camera image, as image_proc's rectify does: the
// camera model of a ROS camera_info (K, D, R, P, size) gives a pixel map, made once, that remaps
// each raw image to the rectified one whose projection is P. ROS-free (OpenCV only).
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <string>
#include <vector>

namespace ekf_vislam {

/// A raw camera as sensor_msgs/CameraInfo describes it (row-major matrices).
struct RawCameraModel {
  int width = 0, height = 0;
  std::string distortion_model;  ///< "plumb_bob", "rational_polynomial" or "equidistant"
  std::vector<double> D;         ///< distortion coefficients (5, 8 and 4 of them)
  std::array<double, 9> K{};     ///< raw intrinsics
  std::array<double, 9> R{};     ///< rotation from the raw camera to the rectified one
  std::array<double, 12> P{};    ///< projection of the rectified image

  bool operator==(const RawCameraModel& other) const;
  bool operator!=(const RawCameraModel& other) const { return !(*this == other); }
};

/// Remaps raw images of one camera to its rectified image (bilinear, the rectified image of the
/// raw image's size). Pixels that fall outside the raw image are black.
class ImageRectifier {
 public:
  /// False with a reason when the model cannot be used: an unknown distortion model, a wrong
  /// number of coefficients, a size, K or P that is not a camera's, R that is not a rotation.
  bool reset(const RawCameraModel& model, std::string* why);
  bool ready() const { return !map_xy_.empty(); }
  /// The model given to the last successful reset(), as given (compare a new camera_info's with
  /// it).
  const RawCameraModel& model() const { return model_; }
  /// `raw` must be 8-bit gray of the model's size (false otherwise, *rectified untouched).
  bool rectify(const cv::Mat& raw, cv::Mat* rectified) const;
  /// Where the rectified image sees a raw pixel (for tests and tools): the model's projection P of
  /// the undistorted, rotated ray.
  cv::Point2d rectifiedPixel(const cv::Point2d& raw_pixel) const;

 private:
  RawCameraModel model_;
  std::vector<double> distortion_;  ///< model_.D padded with zeros to its model's count
  cv::Mat map_xy_, map_fraction_;   ///< cv::initUndistortRectifyMap, fixed point (CV_16SC2)
};

}  // namespace ekf_vislam
