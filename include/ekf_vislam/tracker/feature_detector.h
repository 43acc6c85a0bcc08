// New corners on a grid: each cell is filled up to a count, every new corner keeps a minimum
// distance from existing features and from the others. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_options.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace ekf_vislam {

/// Which of `points` to keep so that no two kept ones lie closer than `min_distance` px: each
/// point in turn is kept unless an earlier kept one is that close. The tracker passes its tracks
/// oldest first, so of tracks that have come together (the camera backing away, a near object
/// passing a far point) the oldest goes on. All kept when min_distance <= 0.
std::vector<uint8_t> keepApart(const std::vector<cv::Point2f>& points, double min_distance);

class GridFeatureDetector {
 public:
  explicit GridFeatureDetector(const TrackerOptions& options) : options_(options) {}

  /// New corners of the 8-bit image in cells holding fewer than max_features_per_cell of
  /// `existing`, strongest first within a cell, at least min_feature_distance from `existing`
  /// and from each other, none within border_px of the image border nor on a zero pixel of
  /// `usable` (8-bit, the image's size; empty: everywhere usable).
  /// `found`: the image's corners from independentCandidates(), when computed beforehand.
  std::vector<cv::Point2f> detect(const cv::Mat& image, const std::vector<cv::Point2f>& existing,
                                  const cv::Mat& usable = cv::Mat(),
                                  const std::vector<cv::KeyPoint>* found = nullptr) const;

  /// Whether the corner search ignores the existing features (FAST: it may run before they are
  /// known, e.g. beside the frame's tracking, and its result go to detect()). Shi-Tomasi's
  /// search skips the features' surroundings.
  bool candidatesIndependent() const { return options_.detector == FeatureDetectorType::kFast; }
  /// The corners detect() selects from, when candidatesIndependent().
  std::vector<cv::KeyPoint> independentCandidates(const cv::Mat& image) const;

  /// Grid cell index of a point (row-major), -1 outside the image.
  int cellOf(const cv::Point2f& point, const cv::Size& size) const;

 private:
  std::vector<cv::KeyPoint> candidates(const cv::Mat& image, const cv::Mat& free_mask) const;
  TrackerOptions options_;
};

}  // namespace ekf_vislam
