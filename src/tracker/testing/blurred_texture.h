// A random texture for the tracker's tests: uniform noise blurred by a Gaussian, stretched to
// 0-255 and stored as 8-bit gray. Deterministic from its seed. No ROS.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace ekf_vislam {
namespace testing {

inline cv::Mat blurredTexture(cv::Size size, int seed, double blur_sigma) {
  cv::Mat noise(size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), blur_sigma);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  cv::Mat texture;
  noise.convertTo(texture, CV_8U);
  return texture;
}

}  // namespace testing
}  // namespace ekf_vislam
