// Counters of what the estimator used and rejected, by reason. No ROS.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace ekf_vislam {

/// Every event the estimator counts. Names (counterName) are the keys of stats.json and of the
/// diagnostics; keep them stable.
enum class Counter : int {
  // Twist messages
  kTwistUsed = 0,
  kTwistNonFinite,      ///< NaN/Inf component: rejected
  kTwistImplausible,    ///< speed beyond limits/max_linear_speed or max_angular_speed: rejected
  kTwistNotIncreasing,  ///< stamp <= previous twist stamp (duplicate or backwards): rejected
  kTwistLate,    ///< older than the filter time (a frame was processed after it): held, no predict
  kTwistGap,     ///< time gap beyond limits/max_twist_gap: handled per gap policy
  kTwistAtRest,  ///< camera at rest (standstill/): pose held, the gyro sample measured the bias
  // Feature messages
  kFrameUsed,
  kFrameEmpty,              ///< no features (prediction still done)
  kFrameStale,              ///< stamp older than the filter time: rejected
  kFrameNoCalibration,      ///< calibration missing or invalid: rejected
  kFrameBeforeTwist,        ///< no twist yet: rejected (the filter has no time origin)
  kFrameRepeated,           ///< shared tracks all identical to the previous frame's
  kFrameCapped,             ///< more than limits/max_features_per_frame: extra features dropped
  kFrameNonFiniteStamp,     ///< stamp NaN/Inf: rejected
  kFramePredictionWidened,  ///< most observations gated: the prediction's noise widened
  kFrameGatedJointly,       ///< most observations gated: gated again after their shared error
  kFrameAtRest,  ///< the camera still at rest (standstill/): the frame's tracks did not update
  // Observations (one feature of one frame)
  kObservationUpdate,        ///< used in an EKF update
  kObservationInitialized,   ///< started a new landmark
  kObsNonFinite,             ///< NaN/Inf coordinate
  kObsDisparity,             ///< disparity below landmarks/min_disparity_px (incl. negative)
  kObsDepth,                 ///< triangulated depth outside [min_depth, max_depth]
  kObsOutsideImage,          ///< coordinates outside the image
  kObsRowMismatch,           ///< |v_left - v_right| beyond limits/max_row_difference_px
  kObsDuplicateId,           ///< id repeated within one frame: all but the first dropped
  kObsGated,                 ///< Mahalanobis distance beyond the chi-square gate
  kObsJumpHeld,              ///< flagged by the flow test once: not used, the landmark stays
  kObsBehindCamera,          ///< predicted point not in front of the camera
  kObsIgnoredDeadReckoning,  ///< dead reckoning mode: observations not used
  kObsWaiting,               ///< new track not started: landmarks/max_active in the state
  kObsAtRest,                ///< in a frame at rest (kFrameAtRest): not used
  kObsTrackDropped,          ///< of a dropped track (kLandmarkTrackDropped): not used
  // Landmark life cycle
  kLandmarkInitialized,
  kLandmarkReinitialized,  ///< a landmark whose first observation was gated out restarted
  kLandmarkMarginalized,
  kLandmarkSplit,  ///< a track reached landmarks/max_track_length: continued as a new landmark
  kLandmarkJump,   ///< a track jumped (flow test): continued as a new landmark
  kLandmarkTrackDropped,  ///< restarted beyond landmarks/max_restarts (a moving point): dropped
  kLandmarkShifted,       ///< tracked through a repeated frame: moved by one frame of motion
  // Filter health
  kCovarianceRepaired,  ///< covariance lost symmetry/positivity and was repaired
  kDivergenceRecovery,  ///< divergence detected; recovery policy applied
  kUpdateNonFinite,     ///< an update produced non-finite numbers and was discarded
  // Accelerometer samples (gravity/)
  kAccelUsed,          ///< accepted (integrated into a gravity window unless between windows)
  kAccelNonFinite,     ///< NaN/Inf component or stamp: rejected
  kAccelImplausible,   ///< |f| outside [0.3 g, 4 g] (no accelerometer at rest reads that): rejected
  kAccelLate,          ///< older than the twists already integrated: dropped
  kGravityUpdate,      ///< gravity windows applied
  kGravityIncomplete,  ///< windows the samples covered less than 90 % of: not used
  kGravityGated,       ///< windows beyond the chi-square gate (0.9999): not used
  kCount
};

/// Stable snake_case name of a counter (e.g. "twist_non_finite").
const char* counterName(Counter counter);

class EstimatorStats {
 public:
  void increment(Counter counter, uint64_t amount = 1) {
    counts_[static_cast<int>(counter)] += amount;
  }
  uint64_t get(Counter counter) const { return counts_[static_cast<int>(counter)]; }
  void clear() { counts_.fill(0); }
  /// Observations rejected for any reason (not used in an update or an initialization).
  uint64_t observationsRejected() const;
  /// Observations the input checks looked at (used, waiting, held or rejected; not those a
  /// dead-reckoning run ignores).
  uint64_t observationsScreened() const;

 private:
  std::array<uint64_t, static_cast<int>(Counter::kCount)> counts_{};
};

}  // namespace ekf_vislam
