// Exposure compensation for the KLT steps: the affine intensity map (gain and offset) between two
// images of the same scene points, fitted from the points themselves, so that a camera's
// automatic exposure (a frame brighter than the last) or two cameras that differ in gain do not
// break the KLT's brightness constancy. No ROS.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

namespace ekf_vislam {

/// The intensity map I' = gain * I + offset (8-bit gray levels).
struct IntensityMap {
  double gain = 1.0;
  double offset = 0.0;
};

/// The map that takes the image `from` to the image `to`, fitted on the same scene points seen at
/// `from_points` in one and `to_points` in the other (equal sizes), from `box` x `box` windows
/// about them (so a point known to a pixel or two serves): the gain is the median ratio of the
/// windows' standard deviations, the offset the median difference of their means after the gain
/// (robust to a few wrong points). Windows outside either image, or flat (or saturated) ones, do
/// not count. No map when fewer than `min_points` count; the gain is held to [1/4, 4].
std::optional<IntensityMap> fitIntensityMap(const cv::Mat& from,
                                            const std::vector<cv::Point2f>& from_points,
                                            const cv::Mat& to,
                                            const std::vector<cv::Point2f>& to_points, int box,
                                            int min_points);

/// `image` (8-bit, one channel) mapped by `map`, saturated to 0-255.
cv::Mat applyIntensityMap(const cv::Mat& image, const IntensityMap& map);

}  // namespace ekf_vislam
