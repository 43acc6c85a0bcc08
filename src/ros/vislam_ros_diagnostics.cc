// VislamRos's /diagnostics: the status summary (the first problem found, in order of urgency),
// the hints that explain it (health_monitor.h), and every input rate and counter.
#include "ekf_vislam/ros/vislam_ros.h"

#include "ekf_vislam/core/estimator_hints.h"
#include "ekf_vislam/core/health_monitor.h"

#include <algorithm>
#include <string>

namespace ekf_vislam {

void VislamRos::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const EstimatorStats& stats = runner_->estimator().stats();
  const ros::WallTime now = ros::WallTime::now();
  const double dt = std::max(1e-3, (now - last_diag_).toSec());
  const double twist_rate = static_cast<double>(twists_received_ - twists_at_last_diag_) / dt;
  const double feature_rate = static_cast<double>(frames_received_ - frames_at_last_diag_) / dt;
  twists_at_last_diag_ = twists_received_;
  frames_at_last_diag_ = frames_received_;
  last_diag_ = now;
  const uint64_t divergence =
      stats.get(Counter::kDivergenceRecovery) + stats.get(Counter::kUpdateNonFinite);
  diverging_ = divergence > divergence_at_last_diag_;
  divergence_at_last_diag_ = divergence;
  setSummary(collectHints(stats, dt), now, status);
  addDiagnosticValues(twist_rate, feature_rate, status);
}

VislamRos::DiagnosticHints VislamRos::collectHints(const EstimatorStats& stats, double dt) {
  DiagnosticHints hints;
  // Inputs that contradict each other (twist axes against the camera tf, calibration, stamps)
  // show as many gated observations, period after period.
  const auto [gated, updated] = *disagreement_window_.close(
      {stats.get(Counter::kObsGated), stats.get(Counter::kObservationUpdate)}, 0);
  hints.disagreement = disagreementHint(options_.mode, gated, updated);
  if (!hints.disagreement.empty()) {
    ROS_WARN_THROTTLE(30.0, "%s: in the last %.1f s %s", name_.c_str(), dt,
                      hints.disagreement.c_str());
  }
  hints.state = stateHints(runner_->estimator());
  const ros::WallTime now = ros::WallTime::now();
  for (size_t i = 0; i < StateHints::kCount; ++i) {  // each at most once a minute
    const std::string& hint = *hints.state.all()[i];
    if (hint.empty() || (now - state_hint_warned_[i]).toSec() < 60.0) continue;
    state_hint_warned_[i] = now;
    ROS_WARN("%s: %s", name_.c_str(), hint.c_str());
  }
  updateObservationRate(stats);
  updateFeatureGeometry(stats);
  return hints;
}

void VislamRos::setSummary(const DiagnosticHints& hints, const ros::WallTime& now,
                           diagnostic_updater::DiagnosticStatusWrapper& status) const {
  using diagnostic_msgs::DiagnosticStatus;
  const bool needs_features = options_.mode != EstimatorMode::kDeadReckoning;
  if (diverging_) {
    status.summary(DiagnosticStatus::ERROR, "divergence detected (recovery applied)");
  } else if (twists_received_ == 0) {
    status.summary(DiagnosticStatus::WARN, "no imu/twist received yet");
  } else if ((now - last_twist_).toSec() > ros_options_.input_timeout) {
    status.summary(DiagnosticStatus::WARN, "imu/twist stopped");
  } else if (needs_features && !runner_->estimator().hasCalibration()) {
    status.summary(DiagnosticStatus::WARN, "no calibration: " + calibration_status_);
  } else if (needs_features && camera_info_changed_ > 0) {
    status.summary(DiagnosticStatus::WARN,
                   "camera_info changed after the calibration was set: the estimator keeps the "
                   "first (restart the node to take the new one)");
  } else if (needs_features && (now - last_features_).toSec() > ros_options_.input_timeout) {
    status.summary(DiagnosticStatus::WARN, "stereo/features stopped");
  } else if (needs_features && !geometry_hint_.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   "most stereo features rejected: images not rectified, or left and right "
                   "swapped? (see the log)");
  } else if (!hints.disagreement.empty() || !widened_hint_.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   hints.disagreement.empty()
                       ? "the prediction disagreed with the images in many frames: do the twist, "
                         "the camera tf and the stamps agree? (see the log)"
                       : "many observations gated: do the twist, the camera tf and the stamps "
                         "agree? (see the log)");
  } else if (!hints.state.travel.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   "the twist does not travel along its x axis: the vehicle prior removes a part "
                   "of the velocity (see the log)");
  } else if (!hints.state.tilt.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   "the road tilt left its prior: the height is not to be trusted (see the log)");
  } else if (!hints.state.slow.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   "noisy angular velocity on a slow drive: less accurate, and too confident "
                   "unless a disparity offset is counted (see the log)");
  } else if (!hints.state.speed.empty() || !hints.state.offset.empty()) {
    // Either error reads partly as the other (both scale the depths against the motion).
    std::string what;
    if (!hints.state.speed.empty())
      what = "the twist's speed errs by more than noise/twist_speed_scale_sigma";
    if (!hints.state.offset.empty()) {
      what += (what.empty() ? "" : "; ");
      what += "the stereo disparities err by more than intrinsic/disparity_offset_counted_sigma";
    }
    status.summary(DiagnosticStatus::WARN,
                   what +
                       ": the reported covariance counts it, the estimate is not corrected "
                       "(see the log)");
  } else if (!sparse_hint_.empty()) {
    status.summary(DiagnosticStatus::WARN,
                   "few observations per frame: the covariance is likely too small (see the log)");
  } else {
    status.summary(DiagnosticStatus::OK, "running");
  }
}

void VislamRos::addDiagnosticValues(double twist_rate, double feature_rate,
                                    diagnostic_updater::DiagnosticStatusWrapper& status) const {
  const VislamEstimator& estimator = runner_->estimator();
  const EstimatorStats& stats = estimator.stats();
  const TravelDirectionEstimator& travel = estimator.travelDirection();
  status.add("mode", modeName(options_.mode));
  status.add("calibration", calibration_status_);
  status.add("camera_info_changed", camera_info_changed_);
  status.add("unknown_parameters", unknown_parameters_.empty() ? "none" : unknown_parameters_);
  status.add("twist_rate_hz", twist_rate);
  status.add("feature_rate_hz", feature_rate);
  status.add("twists_received", twists_received_);
  status.add("twist_covariance_invalid", twist_covariance_invalid_);
  status.add("twist_without_tf", twists_without_tf_);
  status.add("accel_received", accel_received_);
  status.add("accel_without_data", accel_without_data_);
  status.add("accel_without_tf", accel_waiting_.droppedWithoutTf());
  status.add("accel_waiting_for_tf", accel_waiting_.size());
  status.add("gravity_level_tilt_deg", estimator.levelTiltDegrees());
  const Eigen::Vector3d& accel_bias = estimator.accelBias();
  status.add("accel_bias_m_s2", std::to_string(accel_bias.x()) + " " +
                                    std::to_string(accel_bias.y()) + " " +
                                    std::to_string(accel_bias.z()));
  if (!ros_options_.base_frame.empty()) status.add("base_frame_without_tf", base_frame_without_tf_);
  status.add("frames_received", frames_received_);
  status.add("frames_missing", frame_gaps_.missing());
  status.add("time_jump_resets", runner_->timeJumpResets());
  status.add("update_ms_last", last_update_ms_);
  status.add("update_ms_p99", runner_->times().percentile(0.99));
  status.add("latency_ms_p50", runner_->latencies().percentile(0.5));
  status.add("latency_ms_p99", runner_->latencies().percentile(0.99));
  status.add("active_landmarks", estimator.activeLandmarkCount());
  status.add("total_landmarks", estimator.landmarks().size());
  status.add("map_landmarks", landmarksInMap(estimator.landmarks()));
  status.add("state_dimension", estimator.stateDimension());
  status.add("disparity_offset_px", estimator.disparityOffset());
  status.add("disparity_offset_sigma_px", estimator.disparityOffsetSigma());
  status.add("disparity_offset_shown_px", estimator.disparityOffsetMonitor().error());
  status.add("baseline_scale", estimator.baselineScale());
  status.add("twist_speed_scale", estimator.twistSpeedScale());
  status.add("twist_speed_scale_sigma", estimator.twistSpeedScaleSigma());
  status.add("twist_speed_scale_shown", estimator.twistSpeedScaleShown());
  status.add("track_drift_rate_rad_s", estimator.trackDriftRate().norm());
  status.add("track_correlation", estimator.trackCorrelation());
  status.add("twist_linear_noise_density", estimator.linearNoiseDensity());
  status.add("twist_angular_noise_density", estimator.angularNoiseDensity());
  status.add("twist_mean_speed_m_s", estimator.meanTwistSpeed());
  status.add("twist_travel_yaw_deg", travel.yawDegrees());
  status.add("twist_travel_pitch_deg", travel.pitchDegrees());
  status.add("road_tilt_deg", estimator.roadTiltDegrees());
  status.add("road_tilt_error_shown_deg", estimator.roadTiltErrorShownDegrees());
  status.add("observations_per_frame", observations_per_frame_);
  status.add("observations_rejected", stats.observationsRejected());
  for (int i = 0; i < static_cast<int>(Counter::kCount); ++i) {
    status.add(counterName(static_cast<Counter>(i)), stats.get(static_cast<Counter>(i)));
  }
  status.add("frames_without_calibration", runner_->framesWithoutCalibration());
  status.add("odometry_non_finite", odometry_non_finite_);
  status.add("sequencer_late", runner_->sequencerLate());
  status.add("sequencer_buffered", runner_->buffered());
}

void VislamRos::updateObservationRate(const EstimatorStats& stats) {
  static_assert(kWidenedHintMinFrames <= kSparseHintMinFrames, "one window serves both hints");
  const auto window =
      rate_window_.close({stats.get(Counter::kFrameUsed), stats.get(Counter::kObservationUpdate),
                          stats.get(Counter::kFramePredictionWidened)},
                         kSparseHintMinFrames);
  if (!window) return;
  const auto [frames, updates, widened] = *window;
  observations_per_frame_ = static_cast<double>(updates) / static_cast<double>(frames);
  sparse_hint_ = sparseObservationsHint(options_.mode, updates, frames);
  if (!sparse_hint_.empty()) {
    ROS_WARN_THROTTLE(60.0, "%s: %s", name_.c_str(), sparse_hint_.c_str());
  }
  widened_hint_ = widenedPredictionHint(widened, frames);
  if (!widened_hint_.empty()) {
    ROS_WARN_THROTTLE(30.0, "%s: %s", name_.c_str(), widened_hint_.c_str());
  }
}

void VislamRos::updateFeatureGeometry(const EstimatorStats& stats) {
  const auto window =
      geometry_window_.close({stats.observationsScreened(), stats.get(Counter::kObsRowMismatch),
                              stats.get(Counter::kObsDisparity)},
                             kFeatureHintMinObservations);
  if (!window) return;
  const auto [screened, rows, disparity] = *window;
  geometry_hint_ = featureGeometryHint(rows, disparity, screened);
  if (!geometry_hint_.empty()) {
    ROS_WARN_THROTTLE(30.0, "%s: %s", name_.c_str(), geometry_hint_.c_str());
  }
}

// ---------------------------------------------------------------------------------------------
// Services
// ---------------------------------------------------------------------------------------------

}  // namespace ekf_vislam
