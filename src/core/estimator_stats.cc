#include "ekf_vislam/core/estimator_stats.h"

namespace ekf_vislam {

const char* counterName(Counter counter) {
  switch (counter) {
    case Counter::kTwistUsed: return "twist_used";
    case Counter::kTwistNonFinite: return "twist_non_finite";
    case Counter::kTwistImplausible: return "twist_implausible";
    case Counter::kTwistNotIncreasing: return "twist_time_not_increasing";
    case Counter::kTwistLate: return "twist_late";
    case Counter::kTwistGap: return "twist_gap";
    case Counter::kTwistAtRest: return "twist_at_rest";
    case Counter::kFrameUsed: return "frame_used";
    case Counter::kFrameEmpty: return "frame_empty";
    case Counter::kFrameStale: return "frame_stale";
    case Counter::kFrameNoCalibration: return "frame_no_calibration";
    case Counter::kFrameBeforeTwist: return "frame_before_twist";
    case Counter::kFrameRepeated: return "frame_repeated";
    case Counter::kFrameCapped: return "frame_capped";
    case Counter::kFrameNonFiniteStamp: return "frame_non_finite_stamp";
    case Counter::kFramePredictionWidened: return "frame_prediction_widened";
    case Counter::kFrameGatedJointly: return "frame_gated_jointly";
    case Counter::kFrameAtRest: return "frame_at_rest";
    case Counter::kObservationUpdate: return "observation_update";
    case Counter::kObservationInitialized: return "observation_initialized";
    case Counter::kObsNonFinite: return "observation_non_finite";
    case Counter::kObsDisparity: return "observation_disparity";
    case Counter::kObsDepth: return "observation_depth";
    case Counter::kObsOutsideImage: return "observation_outside_image";
    case Counter::kObsRowMismatch: return "observation_row_mismatch";
    case Counter::kObsDuplicateId: return "observation_duplicate_id";
    case Counter::kObsGated: return "observation_gated";
    case Counter::kObsJumpHeld: return "observation_jump_held";
    case Counter::kObsBehindCamera: return "observation_behind_camera";
    case Counter::kObsIgnoredDeadReckoning: return "observation_ignored_deadreckoning";
    case Counter::kObsWaiting: return "observation_waiting";
    case Counter::kObsAtRest: return "observation_at_rest";
    case Counter::kObsTrackDropped: return "observation_track_dropped";
    case Counter::kLandmarkTrackDropped: return "landmark_track_dropped";
    case Counter::kLandmarkInitialized: return "landmark_initialized";
    case Counter::kLandmarkReinitialized: return "landmark_reinitialized";
    case Counter::kLandmarkSplit: return "landmark_split";
    case Counter::kLandmarkJump: return "landmark_jump";
    case Counter::kLandmarkShifted: return "landmark_shifted";
    case Counter::kLandmarkMarginalized: return "landmark_marginalized";
    case Counter::kCovarianceRepaired: return "covariance_repaired";
    case Counter::kDivergenceRecovery: return "divergence_recovery";
    case Counter::kUpdateNonFinite: return "update_non_finite";
    case Counter::kAccelUsed: return "accel_used";
    case Counter::kAccelNonFinite: return "accel_non_finite";
    case Counter::kAccelImplausible: return "accel_implausible";
    case Counter::kAccelLate: return "accel_late";
    case Counter::kGravityUpdate: return "gravity_update";
    case Counter::kGravityIncomplete: return "gravity_window_incomplete";
    case Counter::kGravityGated: return "gravity_gated";
    case Counter::kCount: break;
  }
  return "unknown";
}

uint64_t EstimatorStats::observationsRejected() const {
  uint64_t sum = 0;
  for (Counter c : {Counter::kObsNonFinite, Counter::kObsDisparity, Counter::kObsDepth,
                    Counter::kObsOutsideImage, Counter::kObsRowMismatch, Counter::kObsDuplicateId,
                    Counter::kObsGated, Counter::kObsBehindCamera}) {
    sum += get(c);
  }
  return sum;
}

uint64_t EstimatorStats::observationsScreened() const {
  return observationsRejected() + get(Counter::kObservationUpdate) +
         get(Counter::kObservationInitialized) + get(Counter::kObsWaiting) +
         get(Counter::kObsJumpHeld) + get(Counter::kObsAtRest) + get(Counter::kObsTrackDropped);
}

}  // namespace ekf_vislam
