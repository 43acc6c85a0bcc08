// The raw image a camera takes of a scene given by its rectified image: each raw pixel samples the
// rectified truth where the rectifier's model sees that pixel (bicubic). For the rectifier's tests.
// No ROS.
#pragma once

#include "ekf_vislam/tracker/image_rectifier.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace ekf_vislam {
namespace testing {

inline cv::Mat rawImageOf(const cv::Mat& truth, const ImageRectifier& rectifier) {
  cv::Mat map_x(truth.size(), CV_32F), map_y(truth.size(), CV_32F);
  for (int v = 0; v < truth.rows; ++v) {
    for (int u = 0; u < truth.cols; ++u) {
      const cv::Point2d r = rectifier.rectifiedPixel(cv::Point2d(u, v));
      map_x.at<float>(v, u) = static_cast<float>(r.x);
      map_y.at<float>(v, u) = static_cast<float>(r.y);
    }
  }
  cv::Mat raw;
  cv::remap(truth, raw, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, 0);
  return raw;
}

}  // namespace testing
}  // namespace ekf_vislam
