// The regime hints that read the estimator's own state (health_monitor.h), built in one place
// for the node's /diagnostics and vislam_offline's summary. The hints that count observations
// over a period (gated, sparse, feature geometry) stay with their callers: the node closes a
// window every period, vislam_offline takes the whole run. No ROS.
#pragma once

#include <array>
#include <cstddef>
#include <string>

namespace ekf_vislam {

class VislamEstimator;

struct StateHints {
  std::string travel;  ///< the twist travels off its x axis (travelDirectionHint)
  std::string tilt;    ///< the road tilt left its prior (roadTiltHint)
  std::string slow;    ///< a noisy angular velocity on a slow drive (slowDriveHint)
  std::string speed;   ///< a twist speed error beyond the configured one (speedErrorHint)
  std::string offset;  ///< a disparity offset beyond the configured one (disparityOffsetHint)

  /// Every hint, in the order above (empty ones included).
  static constexpr size_t kCount = 5;
  std::array<const std::string*, kCount> all() const {
    return {&travel, &tilt, &slow, &speed, &offset};
  }
};

/// The estimator's hints now, from its state and its options.
StateHints stateHints(const VislamEstimator& estimator);

}  // namespace ekf_vislam
