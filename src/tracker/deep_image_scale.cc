#include "ekf_vislam/tracker/deep_image_scale.h"

#include <algorithm>
#include <array>
#include <cstdint>

namespace ekf_vislam {

namespace {

// At most this fraction of a pair's pixels may saturate at the bits read from it: a light or a
// reflection in view does not darken the rest of the image.
constexpr double kSaturatedFraction = 0.001;

// How many of the image's pixels need each number of bits (0-16), every other row and column
// counted.
void countBits(const cv::Mat& image, std::array<size_t, 17>* counts) {
  for (int row = 0; row < image.rows; row += 2) {
    const auto* values = image.ptr<uint16_t>(row);
    for (int col = 0; col < image.cols; col += 2) {
      const unsigned value = values[col];
      ++(*counts)[value == 0 ? 0 : 32 - __builtin_clz(value)];
    }
  }
}

// The fewest bits, at least 8, that hold all but kSaturatedFraction of the pair's counted pixels.
int bitsHolding(const std::array<size_t, 17>& counts) {
  size_t total = 0;
  for (const size_t count : counts) total += count;
  const auto allowed = static_cast<size_t>(kSaturatedFraction * static_cast<double>(total));
  size_t above = 0;  // pixels that need more than `bits`
  int bits = 16;
  while (bits > 8 && above + counts[bits] <= allowed) above += counts[bits--];
  return bits;
}

}  // namespace

void DeepImageScale::scalePair(cv::Mat* left, cv::Mat* right) {
  changed_ = false;
  if (left->depth() != CV_16U && right->depth() != CV_16U) return;
  int bits = fixed_bits_;
  if (bits == 0) {
    std::array<size_t, 17> counts{};
    for (const cv::Mat* image : {left, right}) {
      if (image->depth() == CV_16U) countBits(*image, &counts);
    }
    bits = std::max(bits_, bitsHolding(counts));
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
