// Whether the camera stands still, from the tracks alone. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <cstdint>
#include <unordered_map>

namespace ekf_vislam {

/// Recognizes a camera at rest: 80 % of the tracks it shares with a reference frame (at least
/// StandstillOptions::min_tracks) have moved by at most max_displacement_px in the left image.
/// While moving, the reference is the previous frame; once at rest, it stays the frame the rest
/// began in (tracks that start later join it at their first position), so that a slow creep, whose
/// displacement from frame to frame is below the bound, still ends the rest once it has added up to
/// the bound. Frames must come in stamp order.
class StandstillDetector {
 public:
  explicit StandstillDetector(const StandstillOptions& options) : options_(&options) {}

  /// True when `frame` shows the camera where the reference frame saw it; then keeps the
  /// reference, else makes `frame` the reference.
  bool observe(const FeatureFrame& frame);
  bool atRest() const { return at_rest_; }
  void reset();

 private:
  /// The displacement from the reference that 80 % of the finite tracks both share stay within,
  /// or a negative value when they share fewer than min_tracks.
  double displacementQuantile(const FeatureFrame& frame) const;

  const StandstillOptions* options_;  ///< not owned (the estimator keeps it alive)
  std::unordered_map<uint32_t, Eigen::Vector2d> reference_;  ///< id -> (u_left, v_left)
  bool at_rest_ = false;
};

}  // namespace ekf_vislam
