#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace ekf_vislam {

/// Recognizes a feature frame that repeats the previous one: more than half of the tracks the two
/// frames share have exactly the same four coordinates (a fresh measurement of a real tracker
/// differs at least in its sub-pixel digits; "more than half" rather than "all" so that a few
/// corrupted features, gross outliers or NaN, do not hide a repeat). A tracker that re-publishes
/// its last result (a dropped or re-sent image) produces such frames; the KITTI-derived course
/// files contain 8-13 % of them, each followed by tracks that are one image period off their
/// time stamps. Using one would assert that the vehicle did not move over a frame period.
class RepeatedFrameDetector {
 public:
  /// A repeat must share at least `min_shared` tracks with the previous frame.
  explicit RepeatedFrameDetector(int min_shared = 5) : min_shared_(min_shared) {}

  /// True when `frame` repeats the frame given in the previous call; remembers `frame`. When
  /// `new_tracks` is given, it receives the indices of the features whose id the previous frame
  /// did not have (tracks that start in `frame`).
  bool isRepeat(const FeatureFrame& frame, std::vector<size_t>* new_tracks = nullptr);
  void reset() { previous_.clear(); }

 private:
  int min_shared_;
  std::unordered_map<uint32_t, Eigen::Vector4d> previous_;
};

}  // namespace ekf_vislam
