// 16-bit camera images made the 8-bit gray the tracker works on, one scale for both images of a
// pair and for the whole stream.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace ekf_vislam {

/// Both images of a pair, when 16-bit (CV_16U, one channel), are divided by 2^(bits - 8)
/// (rounded, saturated at 255), `bits` the significant bits of the camera's values
/// (ros/image_bits). Fixed at 8-16, or 0: read from the images, the fewest bits (at least 8) that
/// hold all but 0.1 % of a pair's pixels (every other row and column counted), the most of any
/// pair so far. So a 10- or 12-bit camera's values, stored from bit 0 up, fill the 8-bit range,
/// values stored from bit 15 down (or a 16-bit camera's) give their top 8 bits, and a light or a
/// reflection in view does not darken the rest. It only grows: a dark first scene may rescale the
/// stream once or twice later, a gain change the KLT's exposure compensation takes up (up to 4x).
/// (A conversion by the type's range, as cv_bridge's and cv::imread's, leaves a 12-bit camera's
/// image at gray levels 0-16.)
class DeepImageScale {
 public:
  explicit DeepImageScale(int image_bits = 0) : fixed_bits_(image_bits) {}

  /// Scales the 16-bit images of a pair to 8 bits in place (new buffers: the 16-bit data is not
  /// written); 8-bit images stay as they are.
  void scalePair(cv::Mat* left, cv::Mat* right);

  /// The significant bits the last 16-bit pair was scaled by (0 before any).
  int bits() const { return bits_; }
  /// Whether the last pair changed them (the first 16-bit pair, or a higher value met).
  bool changed() const { return changed_; }
  /// "16-bit images: value / 16 tracked (12 significant bits, read from the images)".
  std::string describe() const;

 private:
  int fixed_bits_;
  int bits_ = 0;
  bool changed_ = false;
};

}  // namespace ekf_vislam
