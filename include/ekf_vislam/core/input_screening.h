// Checks of the estimator's inputs before they touch the filter: twists and accelerometer samples
// (finite, plausible) and
// single stereo observations (finite, inside both images, rows agree, positive disparity). No
// ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/feed_result.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <optional>
#include <string>

namespace ekf_vislam {

class InputScreening {
 public:
  explicit InputScreening(const VislamOptions& options) : options_(&options) {}

  /// The reason a twist must be rejected (and a one-line explanation), or nothing.
  std::optional<Counter> checkTwist(const TwistData& twist, std::string* why) const;
  /// The reason an accelerometer sample must be rejected (non-finite; |f| outside [0.3 g, 4 g],
  /// which no accelerometer reads at rest or driving: a message without one), or nothing.
  std::optional<Counter> checkAccelerometer(const AccelerometerData& sample,
                                            std::string* why) const;
  /// The reason one observation cannot be used, or nothing.
  std::optional<Counter> checkObservation(const StereoObservation& f,
                                          const StereoCamera& camera) const;
  /// checkObservation, counting a rejection in stats and result: true when usable.
  bool screen(const StereoObservation& f, const StereoCamera& camera, EstimatorStats* stats,
              FeedResult* result) const;

 private:
  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
};

}  // namespace ekf_vislam
