// A check of the stereo rig from the tracker's own left-right matches: images that are not
// rectified (left and right rows apart) or swapped (the right image's points right of the left
// one's) show in every pair long before the estimator's figures go wrong. Reads the figures of
// TrackerFrameStats over the last pairs and says what to check. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <deque>
#include <string>

namespace ekf_vislam {

class StereoRigCheck {
 public:
  /// `row_tolerance_px`: the tracker's stereo/row_tolerance_px (named in the hint).
  explicit StereoRigCheck(double row_tolerance_px);

  /// Adds one tracked pair's figures; the check reads the last kWindowPairs pairs.
  void add(const TrackerFrameStats& stats);
  /// Forgets every pair (a tracker restart).
  void reset() { pairs_.clear(); }

  /// Over the pairs held: of the left-right matches the KLT ended inside the right image, the
  /// fraction whose rows lie further apart than the tolerance; of the rest, the fraction with
  /// negative disparity; the median of the pairs' median row offsets (v_right - v_left, px).
  /// 0 (offset: 0) without any match.
  double rowFailedFraction() const;
  double negativeDisparityFraction() const;
  double medianRowOffsetPx() const;
  int matchesHeld() const;

  /// What to check, or "" when the rig looks right or too few matches are held
  /// (kMinMatches): more than half of the matches off their row, or more than half of those on
  /// their row with negative disparity.
  std::string hint() const;

  static constexpr int kWindowPairs = 50;
  static constexpr int kMinMatches = 200;

 private:
  struct Pair {
    int converged = 0;
    int row_failed = 0;
    int negative_disparity = 0;
    float row_offset_px = 0;  // NaN without a match
  };
  double row_tolerance_px_;
  std::deque<Pair> pairs_;
};

}  // namespace ekf_vislam
