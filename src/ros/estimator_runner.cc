#include "ekf_vislam/ros/estimator_runner.h"

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstring>
#include <sys/resource.h>
#include <sys/stat.h>

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
    : estimator_(options), sequencer_(sequencing) {}

void EstimatorRunner::push(Measurement measurement) { sequencer_.push(std::move(measurement)); }

size_t EstimatorRunner::processReady(const Observer& observer) {
  const std::vector<Measurement> ready = sequencer_.popReady();
  for (const Measurement& m : ready) feed(m, observer);
  return ready.size();
}

size_t EstimatorRunner::flush(const Observer& observer) {
  const std::vector<Measurement> ready = sequencer_.flush();
  for (const Measurement& m : ready) feed(m, observer);
  return ready.size();
}

void EstimatorRunner::feed(const Measurement& measurement, const Observer& observer) {
  Processed processed;
  processed.stamp = stampOf(measurement);
  if (const TwistData* twist = std::get_if<TwistData>(&measurement)) {
    processed.result = estimator_.feedTwist(*twist);
    ++twists_;
  } else {
    const FeatureFrame& frame = std::get<FeatureFrame>(measurement);
    processed.is_frame = true;
    processed.without_calibration = !estimator_.hasCalibration();
    if (processed.without_calibration) ++frames_without_calibration_;
    const auto start = std::chrono::steady_clock::now();
    processed.result = estimator_.feedFeatures(frame);
    const auto stop = std::chrono::steady_clock::now();
    processed.processing_ms = std::chrono::duration<double, std::milli>(stop - start).count();
    ++frames_;
    if (processed.result.accepted) {
      times_.add(processed.processing_ms);
      StampedPose pose;
      pose.stamp = frame.stamp;
      pose.world_T_imu = estimator_.worldTImu();
      trajectory_.push_back(pose);
    }
  }
  if (std::isfinite(processed.stamp)) {
    if (!has_stamp_) first_stamp_ = processed.stamp;
    has_stamp_ = true;
    first_stamp_ = std::min(first_stamp_, processed.stamp);
    last_stamp_ = std::max(last_stamp_, processed.stamp);
  }
  peak_state_dimension_ = std::max(peak_state_dimension_, estimator_.stateDimension());
  peak_active_landmarks_ = std::max(peak_active_landmarks_, estimator_.activeLandmarkCount());
  if (observer) observer(processed);
}

void EstimatorRunner::reset() {
  estimator_.reset();
  sequencer_.clear();
  trajectory_.clear();
}

RunSummary EstimatorRunner::summary() const {
  RunSummary s;
  s.mode = modeName(estimator_.options().mode);
  s.frames = frames_;
  s.twists = twists_;
  s.landmarks_total = estimator_.landmarks().size();
  s.peak_state_dimension = peak_state_dimension_;
  s.peak_active_landmarks = peak_active_landmarks_;
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  s.data_s = has_stamp_ ? last_stamp_ - first_stamp_ : 0.0;
  s.extra["sequencer_late"] = static_cast<double>(sequencer_.late());
  s.extra["frames_without_calibration"] = static_cast<double>(frames_without_calibration_);
  s.extra["trajectory_poses"] = static_cast<double>(trajectory_.size());
  // Online calibration estimates at the end of the run.
  s.extra["disparity_offset_px"] = estimator_.disparityOffset();
  s.extra["disparity_offset_sigma_px"] = estimator_.disparityOffsetSigma();
  s.extra["baseline_scale"] = estimator_.baselineScale();
  const Vector6d bias = estimator_.twistBias();
  for (int i = 0; i < 3; ++i) {
    s.extra[std::string("gyro_bias_") + "xyz"[i]] = bias(3 + i);
  }
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) == 0) {
    s.extra["peak_rss_mb"] = usage.ru_maxrss / 1024.0;  // Linux: kilobytes; whole process
  }
  return s;
}

bool EstimatorRunner::save(const std::string& dir, std::string* error) const {
  if (!makeDirectories(dir, error)) return false;
  const std::string base = dir.back() == '/' ? dir : dir + "/";
  return writeTumTrajectory(base + "trajectory.tum", trajectory_, error) &&
         writeLandmarksCsv(base + "landmarks.csv", estimator_.landmarks(), error) &&
         writeStatsJson(base + "stats.json", estimator_.stats(), times_, summary(), error);
}

}  // namespace ekf_vislam
