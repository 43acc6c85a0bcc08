// A ground vehicle's tilt follows the road: at most every vehicle/tilt_update_period s of filter
// time, the pseudo-observation that the horizontal part of the IMU's up axis (world axes) equals
// the road tilt state, within the body's own tilt on its suspension (vehicle/body_tilt_sigma).
// The road tilt itself is a Gauss-Markov process over the distance travelled (Propagator). Without
// gravity nothing else holds the roll and pitch: few or drifting tracks turn them, and the
// height error grows with the distance times the pitch error. No ROS.
#pragma once

#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/state_helper.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <optional>

namespace ekf_vislam {

/// The tilt pseudo-observation at one pose, h = (horizontal part of the IMU's up axis, world
/// axes) - (road tilt), observed as 0: the residual -h and the Jacobian of h with respect to the
/// pose's rotation error phi (world axes); the Jacobian with respect to the road tilt is -I.
struct TiltObservation {
  Eigen::Vector2d residual = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 2, 3> H_phi = Eigen::Matrix<double, 2, 3>::Zero();
};

/// world_R_imu's up axis (third column) against the road tilt: h = up.head<2>() - road_tilt.
TiltObservation observeTilt(const Eigen::Matrix3d& world_R_imu,
                            const Eigen::Vector2d& road_tilt_world);

class VehicleTiltUpdater {
 public:
  explicit VehicleTiltUpdater(const VislamOptions& options) : options_(&options) {}

  /// The next update waits a full period again (filter reset).
  void reset() { last_update_time_ = kNever; }
  /// At filter time `time`: applies the pseudo-observation when the state holds the road tilt
  /// and tilt_update_period s have passed since the last one; its outcome, or nothing when none
  /// was due.
  std::optional<UpdateStatus> update(double time, FilterState* state);

 private:
  static constexpr double kNever = -1e300;
  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
  double last_update_time_ = kNever;
};

}  // namespace ekf_vislam
