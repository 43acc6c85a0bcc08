#include "ekf_vislam/tracker/exposure_compensation.h"

#include "ekf_vislam/core/median.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace ekf_vislam {

namespace {

constexpr double kMinGain = 0.25, kMaxGain = 4.0;
// Gray levels: a window with less contrast (flat, or saturated) gives no gain.
constexpr double kMinDeviation = 2.0;

// Mean and standard deviation of the box x box window centred on p (of an 8-bit image), or
// false when the window does not lie inside the image. The sums are exact integers, and the
// result is cv::meanStdDev's, bit for bit, without its per-call dispatch.
bool boxStatistics(const cv::Mat& image, const cv::Point2f& p, int box, double* mean,
                   double* deviation) {
  const int half = box / 2;
  const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
  if (!(u - half >= 0 && v - half >= 0 && u + half < image.cols && v + half < image.rows)) {
    return false;
  }
  int64_t sum = 0, sum_squares = 0;
  for (int r = v - half; r <= v + half; ++r) {
    const uint8_t* row = image.ptr<uint8_t>(r) + (u - half);
    for (int c = 0; c < 2 * half + 1; ++c) {
      sum += row[c];
      sum_squares += row[c] * row[c];
    }
  }
  const double scale = 1.0 / ((2 * half + 1) * (2 * half + 1));
  *mean = sum * scale;
  *deviation = std::sqrt(std::max(sum_squares * scale - *mean * *mean, 0.0));
  return true;
}

}  // namespace

std::optional<IntensityMap> fitIntensityMap(const cv::Mat& from,
                                            const std::vector<cv::Point2f>& from_points,
                                            const cv::Mat& to,
                                            const std::vector<cv::Point2f>& to_points, int box,
                                            int min_points) {
  // Each point's window gives a gain (the ratio of the windows' contrasts, which a shift of a
  // pixel or two barely changes); the map takes the median gain, then the median offset.
  std::vector<double> from_means, to_means, gains;
  for (size_t i = 0; i < from_points.size() && i < to_points.size(); ++i) {
    double from_mean = 0, from_deviation = 0, to_mean = 0, to_deviation = 0;
    if (boxStatistics(from, from_points[i], box, &from_mean, &from_deviation) &&
        boxStatistics(to, to_points[i], box, &to_mean, &to_deviation) &&
        from_deviation >= kMinDeviation && to_deviation >= kMinDeviation) {
      from_means.push_back(from_mean);
      to_means.push_back(to_mean);
      gains.push_back(to_deviation / from_deviation);
    }
  }
  if (static_cast<int>(gains.size()) < std::max(min_points, 1)) return std::nullopt;
  IntensityMap map;
  map.gain = std::clamp(upperMedian(&gains), kMinGain, kMaxGain);
  std::vector<double> offsets(from_means.size());
  for (size_t i = 0; i < offsets.size(); ++i) offsets[i] = to_means[i] - map.gain * from_means[i];
  map.offset = upperMedian(&offsets);
  return map;
}

cv::Mat applyIntensityMap(const cv::Mat& image, const IntensityMap& map) {
  cv::Mat mapped;
  image.convertTo(mapped, CV_8U, map.gain, map.offset);
  return mapped;
}

}  // namespace ekf_vislam
