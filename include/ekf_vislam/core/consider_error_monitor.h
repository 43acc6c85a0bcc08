// The error of a variable the reported covariance alone carries (a consider variable: the twist's
// speed scale, noise/twist_speed_scale_sigma; the rig's disparity offset,
// intrinsic/disparity_offset_counted_sigma) as the camera's observations show it. The reported
// covariance's column of that row is the sensitivity of the state's error to the variable's
// error, so each update's innovations, projected on it, read the error (a least-squares estimate
// over every update, UpdateOutcome::consider), without the estimate ever moving. No ROS.
#pragma once

#include <cstddef>

#include "ekf_vislam/core/state_helper.h"

namespace ekf_vislam {

class ConsiderErrorMonitor {
 public:
  /// One update's evidence (UpdateOutcome::consider).
  void add(const ConsiderEvidence& evidence);
  void clear() { *this = ConsiderErrorMonitor(); }

  size_t updates() const { return updates_; }
  /// The error the observations show, in the variable's unit (the speed scale: true speed /
  /// measured speed - 1, -0.029 for a twist 3 % fast; the disparity offset: measured minus true
  /// disparity, px); 0 without evidence.
  double error() const;
  /// Its standard deviation were the innovations white (real tracks are correlated from frame
  /// to frame: the true spread is larger); infinite without evidence.
  double whiteSigma() const;

 private:
  double score_ = 0.0;
  double information_ = 0.0;
  size_t updates_ = 0;
};

}  // namespace ekf_vislam
