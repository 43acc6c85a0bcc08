// The processing loop shared by the nodelet/node and the offline bag runner, so both feed the
// estimator the same sequence whatever the arrival order and delays: every message goes into the
// MeasurementSequencer, which releases them in stamp order. Propagation is lazy: a released twist
// newer than the last processed frame waits in the runner, and the filter integrates the waiting
// twists up to a feature frame's stamp only when that frame is processed. So a frame that comes
// after later twists (a stalled process reading its backlogs) still finds the filter at or before
// its stamp: only a frame older than the last processed frame is stale. Odometry at twist rate
// comes from a propagated copy of the filter (preview()), which leaves the filter unchanged.
// Also keeps the trajectory (world_T_imu after every feature frame), per-frame processing times,
// frame latencies and the run summary, and writes trajectory.tum, landmarks.csv and stats.json.
// No ROS.
#pragma once

#include "ekf_vislam/core/measurement_sequencer.h"
#include "ekf_vislam/core/output_writers.h"
#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_estimator.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Geometry>

#include <chrono>
#include <deque>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace ekf_vislam {

class EstimatorRunner {
 public:
  /// What happened to one released measurement.
  /// Which stream a released measurement came from.
  using Kind = MeasurementKind;
  struct Processed {
    Kind kind = Kind::kTwist;
    double stamp = 0.0;
    FeedResult result;
    double processing_ms = 0.0;        ///< feedFeatures time (frames only)
    bool without_calibration = false;  ///< frame reached the estimator before the calibration
  };
  using Observer = std::function<void(const Processed&)>;

  /// The filter propagated with every twist pushed so far (filter state untouched).
  struct Preview {
    bool valid = false;  ///< false until the first twist
    double stamp = 0.0;
    Eigen::Isometry3d world_T_imu = Eigen::Isometry3d::Identity();
    Matrix6d pose_covariance_world = Matrix6d::Zero();  ///< as VislamEstimator::poseCovarianceWorld
    TwistData twist;                                    ///< bias-corrected, IMU frame
    Matrix6d twist_covariance = Matrix6d::Zero();
  };

  EstimatorRunner(const VislamOptions& options, const MeasurementSequencer::Options& sequencing);

  VislamEstimator& estimator() { return estimator_; }
  const VislamEstimator& estimator() const { return estimator_; }

  /// Buffers one message; a twist also advances the propagated copy. Call processReady()
  /// afterwards. A feature frame is restamped to when its images were taken on the twist's clock
  /// (its stamp plus extrinsic/camera_time_offset) and is sequenced, used and reported there.
  void push(Measurement measurement);
  /// Live input: a message waiting for another stream is released only after
  /// MeasurementSequencer::Options::max_delay in message time and in wall time (steady clock,
  /// from its push), so a stream that is only late (a loaded machine, a fast bag) loses nothing.
  /// Off (the default, a recorded log read at once): message time alone. Call processReady()
  /// now and then while messages are buffered, so that wall time is acted on without new input.
  void enableWallClockWait(bool enable) { wall_clock_wait_ = enable; }
  /// The propagated copy after the last pushed twist and what processReady() or flush() fed since
  /// (kept only when enabled: it costs a copy of the filter per frame and a second prediction per
  /// twist; off by default).
  const Preview& preview() const { return preview_; }
  void enablePreview(bool enable) { preview_enabled_ = enable; }
  /// Feeds what the sequencer releases; `observer` (optional) sees each one after it was fed.
  size_t processReady(const Observer& observer = Observer());
  /// Feeds everything still buffered, waiting twists included (end of input).
  size_t flush(const Observer& observer = Observer());
  size_t buffered() const { return sequencer_.buffered() + waiting_twists_.size(); }

  /// Estimator reset, sequencer cleared, trajectory cleared. Times and counts are kept.
  void reset();
  /// From now on, a message stamped more than `threshold` s before the newest one of its own
  /// stream (twists, frames, accelerometer samples) means time went back (a bag played again): the
  /// runner resets before taking it (TimeJumpDetector; 0 = never, the default).
  void enableTimeJumpReset(double threshold);
  /// Resets caused by time going back, and how far the last one went (s).
  uint64_t timeJumpResets() const { return time_jump_resets_; }
  double lastTimeJump() const { return time_jumps_.lastJump(); }

  const std::vector<StampedPose>& trajectory() const { return trajectory_; }
  /// Pose covariance (VislamEstimator::poseCovarianceWorld) of each trajectory pose.
  const std::vector<Matrix6d>& trajectoryCovariance() const { return trajectory_covariance_; }
  const ProcessingTimes& times() const { return times_; }
  /// Wall time from a frame's push to the end of its processing, ms.
  const ProcessingTimes& latencies() const { return latencies_; }
  uint64_t framesFed() const { return frames_; }
  uint64_t twistsFed() const { return twists_; }
  uint64_t framesWithoutCalibration() const { return frames_without_calibration_; }
  size_t sequencerLate() const { return sequencer_.late(); }

  /// stats.json content; wall_s is measured from construction (or the last startClock()).
  RunSummary summary() const;
  void startClock() { start_ = std::chrono::steady_clock::now(); }

  /// Writes dir/trajectory.tum, dir/trajectory_covariance.txt, dir/landmarks.csv, dir/stats.json
  /// (creates dir); `extra` adds figures of the caller to stats.json (e.g. the twist combiner's).
  bool save(const std::string& dir, std::string* error,
            const std::map<std::string, double>& extra = {}) const;

 private:
  using Clock = std::chrono::steady_clock;
  /// reset() but for the time-jump detector.
  void clear();
  void feed(const Measurement& measurement, const Observer& observer);
  void feedTwist(const TwistData& twist, const Observer& observer);
  void feedFrame(const FeatureFrame& frame, const Observer& observer);
  /// Integrates the waiting twists up to `stamp` (all of them when stamp is +inf).
  void integrateWaitingTwists(double stamp, const Observer& observer);
  /// The propagated copy after a pushed twist: rebuilt from the filter once a frame made it
  /// stale, else advanced by the twist.
  void updatePreview(const TwistData& twist);
  /// After processing: a frame that went into the filter (released by the twist just pushed, say)
  /// makes the copy stale; it is rebuilt at once, so preview() never shows the filter before it.
  void refreshStalePreview();
  void rebuildPreview();
  void copyPreview();  ///< preview_ from preview_estimator_
  void noteStamp(double stamp);

  /// The steady clock in s (the sequencer's wall time), or `without_wall_clock` when it is off.
  double wallSeconds(double without_wall_clock) const;

  VislamEstimator estimator_;
  MeasurementSequencer sequencer_;
  bool wall_clock_wait_ = false;
  size_t max_waiting_twists_ = 1000;
  std::deque<TwistData> waiting_twists_;  ///< released, newer than the last frame, stamp order
  bool has_frame_ = false;
  double last_frame_stamp_ = 0.0;
  VislamEstimator preview_estimator_;
  bool preview_enabled_ = false;
  bool preview_stale_ = true;  ///< a frame was processed since the copy was made
  Preview preview_;
  std::deque<std::pair<double, Clock::time_point>> frame_arrivals_;  ///< stamp, push time
  ProcessingTimes latencies_;
  std::vector<StampedPose> trajectory_;
  std::vector<Matrix6d> trajectory_covariance_;
  ProcessingTimes times_;
  uint64_t frames_ = 0;
  uint64_t twists_ = 0;
  uint64_t frames_without_calibration_ = 0;
  TimeJumpDetector time_jumps_{0.0, 3};  ///< streams: twists, frames, accelerometer
  uint64_t time_jump_resets_ = 0;
  int peak_state_dimension_ = 0;
  size_t peak_active_landmarks_ = 0;
  double first_stamp_ = 0.0;
  double last_stamp_ = 0.0;
  bool has_stamp_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace ekf_vislam
