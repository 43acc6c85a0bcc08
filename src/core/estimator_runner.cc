#include "ekf_vislam/core/estimator_runner.h"

#include "ekf_vislam/core/late_stream_wait.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

namespace ekf_vislam {

namespace {

// mkdir -p; true when the folder exists afterwards.
bool makeDirectories(const std::string& dir, std::string* error) {
  if (dir.empty()) {
    if (error) *error = "output folder not set";
    return false;
  }
  std::string partial;
  size_t pos = 0;
  while (pos != std::string::npos) {
    pos = dir.find('/', pos + 1);
    partial = dir.substr(0, pos);
    if (partial.empty()) continue;
    if (::mkdir(partial.c_str(), 0775) != 0 && errno != EEXIST) {
      if (error) *error = "cannot create " + partial + ": " + std::strerror(errno);
      return false;
    }
  }
  struct stat info;
  if (::stat(dir.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) {
    if (error) *error = dir + " is not a folder";
    return false;
  }
  return true;
}

}  // namespace

EstimatorRunner::EstimatorRunner(const VislamOptions& options,
                                 const MeasurementSequencer::Options& sequencing)
    : estimator_(options),
      sequencer_(sequencing),
      max_waiting_twists_(std::max<size_t>(1, sequencing.max_buffered)),
      preview_estimator_(options) {}

void EstimatorRunner::push(Measurement measurement) {
  if (FeatureFrame* frame = std::get_if<FeatureFrame>(&measurement)) {
    frame->stamp += estimator_.options().extrinsic.camera_time_offset;
  }
  const MeasurementKind kind = kindOf(measurement);
  if (time_jumps_.jumpedBack(static_cast<int>(kind), stampOf(measurement))) {
    clear();
    ++time_jump_resets_;
  }
  if (const TwistData* twist = std::get_if<TwistData>(&measurement)) {
    const TwistData copy = *twist;
    sequencer_.push(std::move(measurement), wallSeconds(kArrivedLongAgo));
    if (preview_enabled_) updatePreview(copy);
    return;
  }
  if (kind == MeasurementKind::kFrame)
    frame_arrivals_.emplace_back(stampOf(measurement), Clock::now());
  sequencer_.push(std::move(measurement), wallSeconds(kArrivedLongAgo));
}

double EstimatorRunner::wallSeconds(double without_wall_clock) const {
  return wall_clock_wait_ ? steadyClockSeconds() : without_wall_clock;
}

void EstimatorRunner::updatePreview(const TwistData& twist) {
  if (preview_stale_) {
    rebuildPreview();
  } else {
    preview_estimator_.feedTwist(twist);
    copyPreview();
  }
}

void EstimatorRunner::refreshStalePreview() {
  // A frame the last twist released is in the filter now: the copy made before it is not shown.
  if (preview_enabled_ && preview_stale_ && preview_.valid) rebuildPreview();
}

void EstimatorRunner::rebuildPreview() {
  // The filter as it is now, propagated with every twist it has not integrated yet (the one just
  // pushed included: it is in the sequencer already).
  preview_estimator_ = estimator_;
  for (const TwistData& waiting : waiting_twists_) preview_estimator_.feedTwist(waiting);
  for (const TwistData& buffered : sequencer_.bufferedTwists()) {
    preview_estimator_.feedTwist(buffered);
  }
  preview_stale_ = false;
  copyPreview();
}

void EstimatorRunner::copyPreview() {
  if (!preview_estimator_.initialized()) return;
  preview_.valid = true;
  preview_.stamp = preview_estimator_.time();
  preview_.world_T_imu = preview_estimator_.worldTImu();
  preview_.pose_covariance_world = preview_estimator_.poseCovarianceWorld();
  preview_.twist = preview_estimator_.correctedTwist();
  preview_.twist_covariance = preview_estimator_.correctedTwistCovariance();
}

size_t EstimatorRunner::processReady(const Observer& observer) {
  const std::vector<Measurement> ready = sequencer_.popReady(wallSeconds(kNoWallClock));
  for (const Measurement& m : ready) feed(m, observer);
  refreshStalePreview();
  return ready.size();
}

size_t EstimatorRunner::flush(const Observer& observer) {
  const std::vector<Measurement> ready = sequencer_.flush();
  for (const Measurement& m : ready) feed(m, observer);
  integrateWaitingTwists(std::numeric_limits<double>::infinity(), observer);
  refreshStalePreview();
  return ready.size();
}

void EstimatorRunner::feed(const Measurement& measurement, const Observer& observer) {
  if (const TwistData* twist = std::get_if<TwistData>(&measurement)) {
    // Lazy propagation: a twist newer than the last processed frame waits for the next frame (or
    // the end of input). An older one goes in now: the estimator holds it for the next interval.
    const bool waits = !has_frame_ || !(twist->stamp <= last_frame_stamp_);
    if (waits && std::isfinite(twist->stamp)) {
      auto it = std::upper_bound(
          waiting_twists_.begin(), waiting_twists_.end(), twist->stamp,
          [](double stamp, const TwistData& waiting) { return stamp < waiting.stamp; });
      waiting_twists_.insert(it, *twist);
      // Bounded: without frames (a camera that stopped) the oldest twists are integrated.
      while (waiting_twists_.size() > max_waiting_twists_) {
        const TwistData oldest = waiting_twists_.front();
        waiting_twists_.pop_front();
        feedTwist(oldest, observer);
      }
      return;
    }
    feedTwist(*twist, observer);
    return;
  }
  if (const AccelerometerData* sample = std::get_if<AccelerometerData>(&measurement)) {
    // The estimator keeps it until the twists after it are integrated.
    Processed processed;
    processed.kind = Kind::kAccelerometer;
    processed.stamp = sample->stamp;
    processed.result = estimator_.feedAccelerometer(*sample);
    if (observer) observer(processed);
    return;
  }
  feedFrame(std::get<FeatureFrame>(measurement), observer);
}

void EstimatorRunner::integrateWaitingTwists(double stamp, const Observer& observer) {
  while (!waiting_twists_.empty() && waiting_twists_.front().stamp <= stamp) {
    const TwistData twist = waiting_twists_.front();
    waiting_twists_.pop_front();
    feedTwist(twist, observer);
  }
}

void EstimatorRunner::feedTwist(const TwistData& twist, const Observer& observer) {
  Processed processed;
  processed.stamp = twist.stamp;
  processed.result = estimator_.feedTwist(twist);
  ++twists_;
  noteStamp(processed.stamp);
  if (observer) observer(processed);
}

void EstimatorRunner::feedFrame(const FeatureFrame& frame, const Observer& observer) {
  if (std::isfinite(frame.stamp)) integrateWaitingTwists(frame.stamp, observer);
  Processed processed;
  processed.stamp = frame.stamp;
  processed.kind = Kind::kFrame;
  processed.without_calibration = !estimator_.hasCalibration();
  if (processed.without_calibration) ++frames_without_calibration_;
  const auto start = Clock::now();
  processed.result = estimator_.feedFeatures(frame);
  const auto stop = Clock::now();
  processed.processing_ms = std::chrono::duration<double, std::milli>(stop - start).count();
  ++frames_;
  if (processed.result.accepted) {
    times_.add(processed.processing_ms);
    StampedPose pose;
    pose.stamp = frame.stamp;
    pose.world_T_imu = estimator_.worldTImu();
    trajectory_.push_back(pose);
    trajectory_covariance_.push_back(estimator_.poseCovarianceWorld());
    if (!has_frame_ || frame.stamp > last_frame_stamp_) last_frame_stamp_ = frame.stamp;
    has_frame_ = true;
    preview_stale_ = true;
  }
  // Latency: from the push of this frame to now (frames leave the sequencer in stamp order).
  while (!frame_arrivals_.empty() && !(frame_arrivals_.front().first > frame.stamp)) {
    if (frame_arrivals_.front().first == frame.stamp) {
      latencies_.add(
          std::chrono::duration<double, std::milli>(stop - frame_arrivals_.front().second).count());
    }
    frame_arrivals_.pop_front();
  }
  noteStamp(processed.stamp);
  if (observer) observer(processed);
}

void EstimatorRunner::noteStamp(double stamp) {
  if (std::isfinite(stamp)) {
    if (!has_stamp_) first_stamp_ = stamp;
    has_stamp_ = true;
    first_stamp_ = std::min(first_stamp_, stamp);
    last_stamp_ = std::max(last_stamp_, stamp);
  }
  peak_state_dimension_ = std::max(peak_state_dimension_, estimator_.stateDimension());
  peak_active_landmarks_ = std::max(peak_active_landmarks_, estimator_.activeLandmarkCount());
}

void EstimatorRunner::enableTimeJumpReset(double threshold) {
  time_jumps_ = TimeJumpDetector(threshold, 3);
}

void EstimatorRunner::reset() {
  time_jumps_.reset();
  clear();
}

void EstimatorRunner::clear() {
  estimator_.reset();
  sequencer_.clear();
  trajectory_.clear();
  trajectory_covariance_.clear();
  waiting_twists_.clear();
  frame_arrivals_.clear();
  has_frame_ = false;
  preview_stale_ = true;
  preview_ = Preview();
}

RunSummary EstimatorRunner::summary() const {
  RunSummary s;
  s.mode = modeName(estimator_.options().mode);
  s.frames = frames_;
  s.twists = twists_;
  s.landmarks_total = estimator_.landmarks().size();
  s.landmarks_in_map = landmarksInMap(estimator_.landmarks());
  s.peak_state_dimension = peak_state_dimension_;
  s.peak_active_landmarks = peak_active_landmarks_;
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  s.data_s = has_stamp_ ? last_stamp_ - first_stamp_ : 0.0;
  s.extra["sequencer_late"] = static_cast<double>(sequencer_.late());
  s.extra["time_jump_resets"] = static_cast<double>(time_jump_resets_);
  s.extra["latency_ms_p50"] = latencies_.percentile(0.5);
  s.extra["latency_ms_p99"] = latencies_.percentile(0.99);
  s.extra["frames_without_calibration"] = static_cast<double>(frames_without_calibration_);
  s.extra["trajectory_poses"] = static_cast<double>(trajectory_.size());
  // Online calibration estimates at the end of the run.
  s.extra["disparity_offset_px"] = estimator_.disparityOffset();
  s.extra["disparity_offset_sigma_px"] = estimator_.disparityOffsetSigma();
  s.extra["disparity_offset_shown_px"] = estimator_.disparityOffsetMonitor().error();
  s.extra["disparity_offset_shown_white_sigma_px"] =
      estimator_.disparityOffsetMonitor().whiteSigma();
  s.extra["baseline_scale"] = estimator_.baselineScale();
  s.extra["twist_speed_scale"] = estimator_.twistSpeedScale();
  s.extra["twist_speed_scale_sigma"] = estimator_.twistSpeedScaleSigma();
  s.extra["twist_speed_scale_shown"] = estimator_.twistSpeedScaleShown();
  s.extra["twist_speed_scale_shown_white_sigma"] = estimator_.speedErrorMonitor().whiteSigma();
  s.extra["track_correlation"] = estimator_.trackCorrelation();
  s.extra["track_variance_factor"] = estimator_.trackVarianceFactor();
  s.extra["track_noise_recount_factor"] = estimator_.trackNoiseRecountFactor();
  // The twist's noise densities in use (m/s/sqrt(Hz), rad/s/sqrt(Hz)) and its mean forward speed.
  s.extra["twist_linear_noise_density"] = estimator_.linearNoiseDensity();
  s.extra["twist_angular_noise_density"] = estimator_.angularNoiseDensity();
  s.extra["twist_mean_speed_m_s"] = estimator_.meanTwistSpeed();
  // Where the twist travels in its own frame (the vehicle prior assumes along x), degrees.
  s.extra["twist_travel_yaw_deg"] = estimator_.travelDirection().yawDegrees();
  s.extra["twist_travel_pitch_deg"] = estimator_.travelDirection().pitchDegrees();
  s.extra["road_tilt_deg"] = estimator_.roadTiltDegrees();
  // The largest excess of the road tilt over twice its prior: counted as tilt error.
  s.extra["road_tilt_error_shown_deg"] = estimator_.roadTiltErrorShownDegrees();
  // The accelerometer's states (gravity/): the first pose's tilt against gravity, the bias.
  s.extra["gravity_level_tilt_deg"] = estimator_.levelTiltDegrees();
  const Eigen::Vector3d accel_bias_sigma = estimator_.accelBiasSigma();
  for (int i = 0; i < 3; ++i) {
    s.extra[std::string("accel_bias_") + "xyz"[i]] = estimator_.accelBias()(i);
    s.extra[std::string("accel_bias_sigma_") + "xyz"[i]] = accel_bias_sigma(i);
  }
  // Observations that updated the filter per feature frame (few: sparseObservationsHint).
  const EstimatorStats& stats = estimator_.stats();
  s.extra["observations_per_frame"] =
      static_cast<double>(stats.get(Counter::kObservationUpdate)) /
      static_cast<double>(std::max<uint64_t>(1, stats.get(Counter::kFrameUsed)));
  const Vector6d bias = estimator_.twistBias();
  const Eigen::Vector3d& drift = estimator_.trackDriftRate();
  for (int i = 0; i < 3; ++i) {
    s.extra[std::string("gyro_bias_") + "xyz"[i]] = bias(3 + i);
    s.extra[std::string("track_drift_rate_") + "xyz"[i]] = drift(i);
  }
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) == 0) {
    s.extra["peak_rss_mb"] = usage.ru_maxrss / 1024.0;  // Linux: kilobytes; whole process
  }
  return s;
}

bool EstimatorRunner::save(const std::string& dir, std::string* error,
                           const std::map<std::string, double>& extra) const {
  if (!makeDirectories(dir, error)) return false;
  RunSummary run_summary = summary();
  run_summary.extra.insert(extra.begin(), extra.end());
  const std::string base = dir.back() == '/' ? dir : dir + "/";
  return writeTumTrajectory(base + "trajectory.tum", trajectory_, error) &&
         writeTrajectoryCovariance(base + "trajectory_covariance.txt", trajectory_,
                                   trajectory_covariance_, error) &&
         writeLandmarksCsv(base + "landmarks.csv", estimator_.landmarks(), error) &&
         writeStatsJson(base + "stats.json", estimator_.stats(), times_, run_summary, error);
}

}  // namespace ekf_vislam
