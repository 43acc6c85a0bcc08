// A check of the stereo rig from the tracker's own matches: images that are not rectified (left
// and right rows apart), swapped (the right image's points right of the left one's), whose
// disparities are all off by the same amount (a right camera's cx or rectification that
// disagrees with the images: disparity_offset_fit.h), or whose right image is turned against the
// left one (rows apart in proportion to the column: stereo_roll_fit.h) show in every pair long
// before the estimator's figures go wrong. Reads the figures of TrackerFrameStats over the last
// pairs and says what to check. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <deque>
#include <string>
#include <vector>

namespace ekf_vislam {

class StereoRigCheck {
 public:
  /// `row_tolerance_px`: the tracker's stereo/row_tolerance_px (named in the hint);
  /// `offset_corrected`: its stereo/correct_disparity_offset (what the hint says of an offset).
  explicit StereoRigCheck(double row_tolerance_px, bool offset_corrected = false);

  /// Adds one tracked pair's figures; the check reads the last kWindowPairs pairs.
  void add(const TrackerFrameStats& stats);
  /// Forgets every pair and the correction (a tracker restart).
  void reset();

  /// Over the pairs held: of the left-right matches the KLT ended inside the right image, the
  /// fraction whose rows lie further apart than the tolerance; of the rest, the fraction with
  /// negative disparity; the median of the pairs' median row offsets (v_right - v_left, px).
  /// 0 (offset: 0) without any match.
  double rowFailedFraction() const;
  double negativeDisparityFraction() const;
  double medianRowOffsetPx() const;
  int matchesHeld() const;
  /// The median of the held pairs' fitted disparity offsets (measured minus true, px), of those
  /// fitted within kMaxOffsetSigmaPx (pairs that move forward); 0 without one. And their count.
  double medianDisparityOffsetPx() const;
  int disparityOffsetPairs() const;
  /// What a tracker that corrects the offset moves the right columns by (px, added to u_right so
  /// that u_left - u_right is the true disparity). 0 until the median offset lies beyond
  /// kOffsetHintPx (where the hint names it): over kMinOffsetPairs fits or more, or, from
  /// kMinEarlyOffsetPairs fits on, by kEarlyOffsetSigmas standard errors of their median. Rigs
  /// whose images agree with their calibration read up to 0.4 px, and are left as they are. From
  /// then on it is the median after every fitted pair, and holds between (a stop gives no fit),
  /// so it neither switches on and off nor drops at a stop.
  double disparityCorrectionPx() const { return correction_px_; }
  /// Whether that correction has started (and not been reset since).
  bool correcting() const { return correcting_; }
  /// The median of the held pairs' roll of the right image against the left (degrees, positive
  /// clockwise as displayed), of those fitted within kMaxRollSigmaDeg; 0 without one. The median
  /// of the rows' difference it makes at the side edge farther from the principal point (px).
  /// And their count.
  double medianStereoRollDeg() const;
  double medianRollEdgePx() const;
  int stereoRollPairs() const;

  /// What to check, or "" when the rig looks right or too few matches are held
  /// (kMinMatches): more than half of the matches off their row, or more than half of those on
  /// their row with negative disparity; else a median disparity offset beyond kOffsetHintPx
  /// (over how many fits: disparityCorrectionPx); else, with at least kMinRollPairs rolls held,
  /// a roll that moves the rows at the side edge more than kRollHintFraction of the row
  /// tolerance apart.
  std::string hint() const;

  static constexpr int kWindowPairs = 50;
  static constexpr int kMinMatches = 200;
  static constexpr double kMaxOffsetSigmaPx = 0.2;
  static constexpr int kMinOffsetPairs = 10;
  /// Before kMinOffsetPairs fits: from this many on, an offset beyond kOffsetHintPx by
  /// kEarlyOffsetSigmas standard errors of the fits' median counts, their scatter taken as at
  /// least kMinOffsetScatterPx (real rigs' fits scatter by 0.10-0.36 px from pair to pair, more
  /// than each fit's own sigma says; a few can agree closer by chance).
  static constexpr int kMinEarlyOffsetPairs = 3;
  static constexpr double kEarlyOffsetSigmas = 2.0;
  static constexpr double kMinOffsetScatterPx = 0.15;
  /// Half a pixel: 5 % of the depth at 10 px of disparity (39 m on KITTI's rig). Rigs whose
  /// images agree with their calibration read 0.4 px at most (doc/tracker.md).
  static constexpr double kOffsetHintPx = 0.5;
  /// A frame's roll is read from a few hundred matches to 0.004-0.005 degrees (KITTI clips).
  static constexpr double kMaxRollSigmaDeg = 0.02;
  static constexpr int kMinRollPairs = 10;
  /// Three quarters of the row tolerance at the side edge: with the rows' own noise (0.3 px std on
  /// the KITTI clips) a fifth of the matches there then fail the row test, and more with every
  /// tenth of a pixel. The KITTI clips read 0.16-0.51 px at their default tolerance of 1 px
  /// (doc/tracker.md).
  static constexpr double kRollHintFraction = 0.75;

 private:
  struct Pair {
    int converged = 0;
    int row_failed = 0;
    int negative_disparity = 0;
    float row_offset_px = 0;        // NaN without a match
    float disparity_offset_px = 0;  // NaN without a fit within kMaxOffsetSigmaPx
    float roll_deg = 0;             // NaN without a fit within kMaxRollSigmaDeg
    float roll_edge_px = 0;         // NaN with roll_deg
  };
  // The upper median of one of the held pairs' figures, NaN ones left out; 0 without any.
  double medianOfFinite(float Pair::*figure) const;
  // One of the held pairs' figures, NaN ones left out, in the pairs' order.
  std::vector<float> finiteValues(float Pair::*figure) const;
  // How many held pairs have a finite figure.
  int countFinite(float Pair::*figure) const;
  // The offsets held lie beyond kOffsetHintPx (disparityCorrectionPx): the hint names the
  // offset, and a correction starts.
  bool offsetBeyondHint() const;

  double row_tolerance_px_;
  bool offset_corrected_;
  std::deque<Pair> pairs_;
  bool correcting_ = false;  ///< an offset beyond kOffsetHintPx has been read
  double correction_px_ = 0;
};

}  // namespace ekf_vislam
