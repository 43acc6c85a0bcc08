// The twist's speed error as the camera's observations show it, where the speed scale is only
// counted in the reported covariance (noise/twist_speed_scale_sigma), not estimated. The
// reported covariance's column of that row is the sensitivity of the state's error to the scale
// error, so each update's innovations, projected on it, read the error (a least-squares estimate
// over every update, UpdateOutcome::consider_*), without the estimate ever moving. No ROS.
#pragma once

#include <cstddef>

namespace ekf_vislam {

class SpeedErrorMonitor {
 public:
  /// One update's evidence (StereoUpdateOutcome::speed_scale_score and _information).
  void add(double score, double information);
  void clear() { *this = SpeedErrorMonitor(); }

  size_t updates() const { return updates_; }
  /// The scale error the observations show: true speed / measured speed - 1 (-0.029 for a twist
  /// 3 % fast); 0 without evidence.
  double scaleError() const;
  /// Its standard deviation were the innovations white (real tracks are correlated from frame
  /// to frame: the true spread is larger); infinite without evidence.
  double whiteSigma() const;

 private:
  double score_ = 0.0;
  double information_ = 0.0;
  size_t updates_ = 0;
};

}  // namespace ekf_vislam
