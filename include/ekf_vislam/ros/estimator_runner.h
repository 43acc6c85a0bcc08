// The processing loop shared by the nodelet/node and the offline bag runner, so both feed the
// estimator the same sequence: every message goes into the MeasurementSequencer; what it
// releases goes to the estimator in stamp order (predict on a twist, update on a feature frame).
// Also keeps the trajectory (world_T_imu after every feature frame), per-frame processing times
// and the run summary, and writes trajectory.tum, landmarks.csv and stats.json. No ROS.
#pragma once

#include "ekf_vislam/core/measurement_sequencer.h"
#include "ekf_vislam/core/output_writers.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_estimator.h"
#include "ekf_vislam/core/vislam_options.h"

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace ekf_vislam {

class EstimatorRunner {
 public:
  /// What happened to one released measurement.
  struct Processed {
    bool is_frame = false;
    double stamp = 0.0;
    FeedResult result;
    double processing_ms = 0.0;  ///< feedFeatures time (frames only)
    bool without_calibration = false;  ///< frame reached the estimator before the calibration
  };
  using Observer = std::function<void(const Processed&)>;

  EstimatorRunner(const VislamOptions& options, const MeasurementSequencer::Options& sequencing);

  VislamEstimator& estimator() { return estimator_; }
  const VislamEstimator& estimator() const { return estimator_; }

  /// Buffers one message. Call processReady() afterwards.
  void push(Measurement measurement);
  /// Feeds what the sequencer releases; `observer` (optional) sees each one after it was fed.
  size_t processReady(const Observer& observer = Observer());
  /// Feeds everything still buffered (end of input).
  size_t flush(const Observer& observer = Observer());
  size_t buffered() const { return sequencer_.buffered(); }

  /// Estimator reset, sequencer cleared, trajectory cleared. Times and counts are kept.
  void reset();

  const std::vector<StampedPose>& trajectory() const { return trajectory_; }
  const ProcessingTimes& times() const { return times_; }
  uint64_t framesFed() const { return frames_; }
  uint64_t twistsFed() const { return twists_; }
  uint64_t framesWithoutCalibration() const { return frames_without_calibration_; }
  size_t sequencerLate() const { return sequencer_.late(); }

  /// stats.json content; wall_s is measured from construction (or the last startClock()).
  RunSummary summary() const;
  void startClock() { start_ = std::chrono::steady_clock::now(); }

  /// Writes dir/trajectory.tum, dir/landmarks.csv, dir/stats.json (creates dir).
  bool save(const std::string& dir, std::string* error) const;

 private:
  void feed(const Measurement& measurement, const Observer& observer);

  VislamEstimator estimator_;
  MeasurementSequencer sequencer_;
  std::vector<StampedPose> trajectory_;
  ProcessingTimes times_;
  uint64_t frames_ = 0;
  uint64_t twists_ = 0;
  uint64_t frames_without_calibration_ = 0;
  int peak_state_dimension_ = 0;
  size_t peak_active_landmarks_ = 0;
  double first_stamp_ = 0.0;
  double last_stamp_ = 0.0;
  bool has_stamp_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace ekf_vislam
