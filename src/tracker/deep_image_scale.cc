#include "ekf_vislam/tracker/deep_image_scale.h"

#include <algorithm>
#include <cstdint>

namespace ekf_vislam {

namespace {

// The number of bits a value needs (0 for 0).
int bitsOf(double value) {
  int bits = 0;
  for (auto v = static_cast<uint32_t>(value); v != 0; v >>= 1) ++bits;
  return bits;
}

}  // namespace

void DeepImageScale::scalePair(cv::Mat* left, cv::Mat* right) {
  changed_ = false;
  if (left->depth() != CV_16U && right->depth() != CV_16U) return;
  int bits = fixed_bits_;
  if (bits == 0) {
    bits = std::max(bits_, 8);
    for (const cv::Mat* image : {left, right}) {
      if (image->depth() != CV_16U) continue;
      double highest = 0.0;
      cv::minMaxLoc(*image, nullptr, &highest);
      bits = std::max(bits, bitsOf(highest));
    }
  }
  changed_ = bits != bits_;
  bits_ = bits;
  const double scale = 1.0 / static_cast<double>(1 << (bits - 8));
  for (cv::Mat* image : {left, right}) {
    if (image->depth() != CV_16U) continue;
    cv::Mat scaled;  // the 16-bit image may be a message's own data
    image->convertTo(scaled, CV_8U, scale);
    *image = scaled;
  }
}

std::string DeepImageScale::describe() const {
  return "16-bit images: value / " + std::to_string(1 << (bits_ - 8)) + " tracked (" +
         std::to_string(bits_) + " significant bits, " +
         (fixed_bits_ == 0 ? "read from the images" : "ros/image_bits") + ")";
}

}  // namespace ekf_vislam
