#include "ekf_vislam/tracker/debug_drawing.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

namespace ekf_vislam {

namespace {

// The image in BGR, its masked pixels (zero in `mask`, when of its size) at a third.
cv::Mat toBgr(const cv::Mat& image, const cv::Mat& mask) {
  cv::Mat bgr;
  if (image.channels() == 1) {
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = image.clone();
  }
  if (!mask.empty() && mask.size() == image.size()) {
    cv::Mat dimmed;
    bgr.convertTo(dimmed, -1, 1.0 / 3.0);
    dimmed.copyTo(bgr, mask == 0);
  }
  return bgr;
}

// New tracks blue, then cyan -> green -> yellow -> red with age (10 frames and older: red).
cv::Scalar ageColor(int age) {
  if (age == 0) return cv::Scalar(255, 80, 0);
  const double t = std::min(1.0, (age - 1) / 9.0);
  return cv::Scalar(255 * std::max(0.0, 1 - 2 * t), 255 * std::min(1.0, 2 - 2 * t),
                    255 * std::min(1.0, 2 * t));
}

}  // namespace

cv::Mat drawStereoTracks(const cv::Mat& left, const cv::Mat& right, const StereoFrame& frame,
                         const StereoMasks& masks) {
  cv::Mat canvas;
  cv::vconcat(toBgr(left, masks.left), toBgr(right, masks.right), canvas);
  const cv::Point2f down(0.f, static_cast<float>(left.rows));
  // The right match as measured in the image: the published column holds the rig's disparity
  // correction (stereo/correct_disparity_offset).
  const cv::Point2f corrected(frame.stats.disparity_offset_corrected_px, 0.f);
  for (const TrackedFeature& f : frame.features) {
    const cv::Scalar color = ageColor(f.age);
    for (size_t i = 0; i < f.trail.size(); ++i) {
      const cv::Point2f& next = i + 1 < f.trail.size() ? f.trail[i + 1] : f.left;
      cv::line(canvas, f.trail[i], next, color, 1, cv::LINE_AA);
    }
    cv::circle(canvas, f.left, 3, color, 1, cv::LINE_AA);
    const cv::Point2f right_in_image = f.right - corrected + down;
    cv::line(canvas, f.left + down, right_in_image, cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
    cv::circle(canvas, right_in_image, 3, color, 1, cv::LINE_AA);
  }
  char text[160];
  std::snprintf(text, sizeof(text),
                "t=%.3f s  features %d  new %d  lost: klt %d fb %d ransac %d "
                "stereo %d disparity %d",
                frame.stamp, frame.stats.published, frame.stats.new_tracks, frame.stats.klt_lost,
                frame.stats.forward_backward_rejected, frame.stats.ransac_rejected,
                frame.stats.stereo_lost, frame.stats.disparity_rejected);
  cv::putText(canvas, text, cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(canvas, text, cv::Point(8, 18), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::putText(canvas, "left: tracks (blue new, green young, red old)", cv::Point(8, left.rows - 8),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::putText(canvas, "right: stereo matches (orange: left position -> right match)",
              cv::Point(8, 2 * left.rows - 8), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return canvas;
}

}  // namespace ekf_vislam
