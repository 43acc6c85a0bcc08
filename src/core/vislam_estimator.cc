#include "ekf_vislam/core/vislam_estimator.h"

#include "ekf_vislam/core/chi_square.h"
#include "ekf_vislam/core/landmark_drift.h"
#include "ekf_vislam/core/pose_covariance.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/twist_at_rest.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>

namespace ekf_vislam {

namespace {

// s: a longer time between processed frames drifts the landmarks as this long.
constexpr double kMaxDriftInterval = 1.0;
// A reported sigma is raised to an error the data show only when short of it by more than this
// fraction (each raise is an O(n^2) update of the reported covariance).
constexpr double kShownErrorTolerance = 0.01;
// The error of a counted variable the observations show (noise/count_observed_speed_error,
// intrinsic/count_shown_disparity_offset) is read once its white sigma is this fraction of the
// configured one or less, and counted less kShownErrorSigmas of them.
constexpr double kShownErrorEvidence = 0.25;
constexpr double kShownErrorSigmas = 2.0;
// A road tilt estimated beyond this many vehicle/tilt_sigma shows the excess as tilt error
// (vehicle/count_shown_tilt_error).
constexpr double kShownTiltErrorSigmas = 2.0;

// Degrees between the vertical and an up axis whose horizontal part is `horizontal`.
double tiltDegrees(const Eigen::Vector2d& horizontal) {
  return std::asin(std::min(1.0, horizontal.norm())) * 180.0 / M_PI;
}

StateLayout layoutFor(const VislamOptions& options) {
  StateLayout layout;
  if (options.bias.estimate_velocity_bias) {
    layout.bias_components.insert(layout.bias_components.end(), {0, 1, 2});
  }
  if (options.bias.estimate_gyro_bias) {
    layout.bias_components.insert(layout.bias_components.end(), {3, 4, 5});
  }
  layout.speed_scale_dim = estimatesSpeedScale(options) || countsSpeedScale(options) ? 1 : 0;
  layout.rotation_dim = options.extrinsic.estimate_twist_rotation ? 3 : 0;
  layout.disparity_dim =
      options.intrinsic.estimate_disparity_offset || countsDisparityOffset(options) ? 1 : 0;
  layout.scale_dim = options.intrinsic.estimate_baseline_scale ? 1 : 0;
  layout.drift_dim =
      options.track_drift.estimate_rate && options.mode != EstimatorMode::kDeadReckoning ? 3 : 0;
  // The clone: the pose at the last repeated frame, and with a correlated pixel error the pose
  // at the previous frame.
  const bool clone = options.limits.repeated_frames == RepeatedFramePolicy::kShift ||
                     options.noise.pixel_correlation > 0.0;
  layout.clone_dim = clone && options.mode == EstimatorMode::kSlam ? StateLayout::kPoseDim : 0;
  layout.reported_covariance = carriesReportedCovariance(options);
  layout.tilt_dim =
      options.vehicle.tilt_sigma > 0.0 && options.mode == EstimatorMode::kSlam ? 2 : 0;
  return layout;
}

}  // namespace

VislamEstimator::VislamEstimator(const VislamOptions& options)
    : options_(std::make_shared<const VislamOptions>(options)),
      state_(layoutFor(*options_)),
      screening_(*options_),
      propagator_(*options_),
      tilt_updater_(*options_),
      gravity_updater_(*options_),
      updater_(*options_),
      landmarks_(*options_),
      repeated_handler_(*options_),
      restart_limiter_(options_->landmarks.max_restarts, options_->landmarks.max_track_gap),
      health_(*options_),
      standstill_(options_->standstill) {
  initializeState();
}

bool VislamEstimator::setCalibration(const StereoCalibration& calibration, std::string* error) {
  const std::string why = calibration.validate();
  if (!why.empty()) {
    if (error != nullptr) *error = "invalid calibration: " + why;
    return false;
  }
  nominal_calibration_ = calibration;
  has_calibration_ = true;
  camera_ = scaledStereoCamera(nominal_calibration_, state_.baseline_scale_error);
  return true;
}

StatePrior VislamEstimator::prior() const {
  const VislamOptions& o = *options_;
  StatePrior prior;
  prior.position_sigma = o.prior.position_sigma;
  prior.rotation_sigma = o.prior.rotation_sigma;
  prior.velocity_bias_sigma = o.bias.velocity_prior_sigma;
  prior.gyro_bias_sigma = o.bias.gyro_prior_sigma;
  prior.speed_scale_reported_only = !estimatesSpeedScale(o);
  prior.speed_scale_sigma = prior.speed_scale_reported_only ? o.noise.twist_speed_scale_sigma
                                                            : o.bias.speed_scale_prior_sigma;
  prior.twist_rotation_sigma = o.extrinsic.twist_rotation_prior_sigma;
  prior.disparity_offset_reported_only = countsDisparityOffset(o);
  prior.disparity_offset_sigma = prior.disparity_offset_reported_only
                                     ? o.intrinsic.disparity_offset_counted_sigma
                                     : o.intrinsic.disparity_offset_prior_sigma;
  prior.baseline_scale_sigma = o.intrinsic.baseline_scale_prior_sigma;
  prior.track_drift_rate_sigma = o.track_drift.rate_prior_sigma;
  prior.road_tilt_sigma = o.vehicle.body_tilt_sigma;
  prior.level_sigma = o.gravity.level_sigma;
  prior.accel_bias_sigma = o.gravity.accel_bias_sigma;
  return prior;
}

void VislamEstimator::resetToPrior() {
  state_.setPrior(prior());
  repeated_handler_.clear();
  holding_still_ = false;
}

void VislamEstimator::initializeState() {
  initialized_ = false;
  time_ = 0.0;
  last_twist_stamp_ = 0.0;
  in_twist_gap_ = false;
  has_frame_ = false;
  repeated_frames_.reset();
  standstill_.reset();
  holding_still_ = false;
  jump_test_paused_ = false;
  last_frame_stamp_ = 0.0;
  drift_stamp_ = std::numeric_limits<double>::quiet_NaN();
  held_twist_ = TwistData();
  propagator_.resetTwistEstimates();
  tilt_updater_.reset();
  gravity_updater_.reset();
  updater_.reset();
  state_.reset(prior());
  repeated_handler_.clear();
  if (has_calibration_) camera_ = scaledStereoCamera(nominal_calibration_, 0.0);
  landmarks_.clear();
  restart_limiter_.reset();
  health_.reset();
  speed_monitor_.clear();
  disparity_monitor_.clear();
  disparity_offset_counted_shown_ = 0.0;
}

void VislamEstimator::reset() { initializeState(); }

// ---------------------------------------------------------------------------------------------
// Prediction
// ---------------------------------------------------------------------------------------------

FeedResult VislamEstimator::feedTwist(const TwistData& twist) {
  FeedResult result;
  auto reject = [&](Counter counter, const std::string& why) {
    stats_.increment(counter);
    result.accepted = false;
    result.message = why;
    return result;
  };
  std::string why;
  if (const std::optional<Counter> bad = screening_.checkTwist(twist, &why)) {
    return reject(*bad, why);
  }
  if (!initialized_) {
    initialized_ = true;
    time_ = last_twist_stamp_ = twist.stamp;
    held_twist_ = twist;
    stats_.increment(Counter::kTwistUsed);
    return result;
  }
  if (twist.stamp <= last_twist_stamp_) {
    std::ostringstream text;
    text << "twist stamp " << std::fixed << twist.stamp << " not after the previous twist ("
         << last_twist_stamp_
         << "): " << (twist.stamp == last_twist_stamp_ ? "duplicate" : "time went backwards");
    return reject(Counter::kTwistNotIncreasing, text.str());
  }
  const double previous_twist_stamp = last_twist_stamp_;
  propagator_.setSamplePeriod(twist.stamp - last_twist_stamp_);
  propagator_.observeTwist(twist);
  checkTwistAtRest(twist);
  last_twist_stamp_ = twist.stamp;
  if (twist.stamp < time_) {
    // A feature frame after this stamp was already processed: keep it for the next interval.
    held_twist_ = twist;
    stats_.increment(Counter::kTwistLate);
    result.message = "twist older than the filter time: held without prediction";
    return result;
  }
  const bool was_holding_still = holding_still_;
  advanceTo(twist.stamp, twist, previous_twist_stamp, &result);
  in_twist_gap_ = false;
  held_twist_ = twist;
  if (time_ == twist.stamp) {
    if (was_holding_still && holding_still_) {
      measureGyroBiasAtRest(twist, twist.stamp - previous_twist_stamp);
    }
    updateGravity(twist);
  }
  stats_.increment(Counter::kTwistUsed);
  return result;
}

FeedResult VislamEstimator::feedAccelerometer(const AccelerometerData& sample) {
  FeedResult result;
  if (!usesAccelerometer(*options_)) return result;
  std::string why;
  if (const std::optional<Counter> bad = screening_.checkAccelerometer(sample, &why)) {
    stats_.increment(*bad);
    result.accepted = false;
    result.message = why;
    return result;
  }
  if (!gravity_updater_.addSample(sample, &stats_)) {
    result.accepted = false;
    result.message = "accelerometer sample older than the twists already integrated: dropped";
  }
  return result;
}

void VislamEstimator::updateGravity(const TwistData& twist) {
  // Without an accelerometer sample yet, nothing to integrate: no work at twist rate.
  if (!usesAccelerometer(*options_) || !gravity_updater_.hasSamples()) return;
  const Vector6d u = propagator_.correctedTwist(state_, twist);
  // d w_corrected / d bias: the rate rows of the bias columns of the prediction's du/daux; d
  // v_corrected / d speed scale: the velocity rows of its column.
  const StateLayout& layout = state_.layout();
  const Eigen::MatrixXd du_daux = propagator_.twistJacobian(state_, twist, u);
  const Eigen::MatrixXd d_w_d_bias = du_daux.bottomLeftCorner(3, layout.biasDim());
  const Eigen::Vector3d d_v_d_scale =
      layout.speed_scale_dim > 0
          ? Eigen::Vector3d(du_daux.block<3, 1>(0, layout.speedScaleRow() - StateLayout::kPoseDim))
          : Eigen::Vector3d::Zero();
  const std::optional<UpdateStatus> status =
      gravity_updater_.onTwist(twist.stamp, u, propagator_.sampleCovariance(state_, twist),
                               d_w_d_bias, d_v_d_scale, &state_, &stats_);
  if (status && *status != UpdateStatus::kApplied) stats_.increment(Counter::kUpdateNonFinite);
}

void VislamEstimator::advanceTo(double stamp, const TwistData& twist, double twist_stamp,
                                FeedResult* result) {
  const VislamOptions& o = *options_;
  const double dt = stamp - time_;
  if (dt <= 0.0) return;
  double noise_scale = 1.0;
  const double since_twist = stamp - twist_stamp;
  if (since_twist > o.limits.max_twist_gap) {
    // No twist for too long (whether frames kept coming or not): once per gap, apply the policy.
    noise_scale = o.limits.gap_noise_scale;
    jump_test_paused_ = true;
    if (!in_twist_gap_) {
      in_twist_gap_ = true;
      stats_.increment(Counter::kTwistGap);
      std::ostringstream why;
      why << "no twist for " << since_twist
          << " s (limits/max_twist_gap = " << o.limits.max_twist_gap << " s): ";
      if (o.limits.gap_policy == GapPolicy::kReset) {
        why << "filter reset (map kept)";
        landmarks_.remove(std::vector<bool>(landmarks_.activeCount(), true),
                          /*count_as_marginalized=*/true, &state_, &stats_);
        state_.imu_T_world.setIdentity();
        state_.bias.setZero();
        resetToPrior();
        time_ = stamp;
        result->message = why.str();
        return;
      }
      why << "predicting across with process noise x " << o.limits.gap_noise_scale;
      result->message = why.str();
    }
  }
  if (holding_still_) {
    propagator_.holdStill(dt, &state_);
  } else {
    propagator_.predict(dt, twist, noise_scale, &state_);
  }
  time_ = stamp;
  const std::optional<UpdateStatus> tilt = tilt_updater_.update(time_, &state_);
  if (tilt && *tilt != UpdateStatus::kApplied) stats_.increment(Counter::kUpdateNonFinite);
}

// ---------------------------------------------------------------------------------------------
// Feature frames
// ---------------------------------------------------------------------------------------------

std::optional<Counter> VislamEstimator::checkFrame(const FeatureFrame& frame,
                                                   std::string* why) const {
  if (!std::isfinite(frame.stamp)) {
    *why = "feature frame with NaN/Inf stamp rejected";
    return Counter::kFrameNonFiniteStamp;
  }
  if (!initialized_) {
    *why = "feature frame before the first twist rejected";
    return Counter::kFrameBeforeTwist;
  }
  if (!has_calibration_) {
    *why = "feature frame rejected: no valid stereo calibration yet";
    return Counter::kFrameNoCalibration;
  }
  if (frame.stamp < time_ || (has_frame_ && frame.stamp <= last_frame_stamp_)) {
    std::ostringstream text;
    text << "feature frame " << std::fixed << frame.stamp
         << (has_frame_ && frame.stamp == last_frame_stamp_ ? " repeats the previous frame"
                                                            : " is older than the filter time")
         << ": rejected";
    *why = text.str();
    return Counter::kFrameStale;
  }
  return std::nullopt;
}

FeedResult VislamEstimator::feedFeatures(const FeatureFrame& frame) {
  FeedResult result;
  std::string why;
  if (const std::optional<Counter> bad = checkFrame(frame, &why)) {
    stats_.increment(*bad);
    result.accepted = false;
    result.message = why;
    result.observations_rejected = static_cast<int>(frame.features.size());
    return result;
  }
  advanceTo(frame.stamp, held_twist_, last_twist_stamp_, &result);
  has_frame_ = true;
  last_frame_stamp_ = frame.stamp;
  stats_.increment(Counter::kFrameUsed);
  if (frame.features.empty()) stats_.increment(Counter::kFrameEmpty);
  const RepeatedFramePolicy policy = options_->limits.repeated_frames;
  landmarks_.beginFrame(frame.stamp);
  std::vector<size_t> new_tracks;
  if (repeated_frames_.isRepeat(frame, &new_tracks)) {
    stats_.increment(Counter::kFrameRepeated);
    if (policy != RepeatedFramePolicy::kUse) {
      // Predicted to its stamp (the trajectory has a pose there); its shared tracks are copies.
      result.message =
          "feature frame repeats the previous one (every shared track identical): skipped";
      if (policy == RepeatedFramePolicy::kShift &&
          options_->mode != EstimatorMode::kDeadReckoning) {
        repeated_handler_.hold(frame, new_tracks, screening_, camera_, &state_, &landmarks_,
                               &stats_, &result);
        landmarks_.syncMap(state_, time_);
      }
      return result;
    }
  }
  if (options_->mode == EstimatorMode::kDeadReckoning) {
    stats_.increment(Counter::kObsIgnoredDeadReckoning, frame.features.size());
    return result;
  }
  // The landmarks drift with their tracks over the time since the last processed frame.
  const double drift_interval =
      std::isnan(drift_stamp_) ? 0.0 : std::min(frame.stamp - drift_stamp_, kMaxDriftInterval);
  landmark_drift::apply(camera_, options_->noise.track_random_walk, drift_interval, &state_);
  drift_stamp_ = frame.stamp;
  // At rest since the last frame: the pose was held over the interval, and this frame's tracks
  // repeat the last view. The first frame at rest still updates (the interval before it moved).
  const bool at_rest =
      options_->mode == EstimatorMode::kSlam && standstill_.observe(frame) && !twist_moved_;
  twist_moved_ = false;
  const bool view_repeated = at_rest && holding_still_;
  holding_still_ = at_rest;
  processFrame(frame, view_repeated, &result);
  return result;
}

int VislamEstimator::collectCandidates(const FeatureFrame& frame, size_t count,
                                       std::unordered_set<uint32_t>* present,
                                       std::vector<StereoCandidate>* updates,
                                       std::vector<StereoCandidate>* initializations,
                                       FeedResult* result) {
  // Every id present keeps its track alive, even when its observation is rejected.
  present->reserve(2 * count);
  updates->reserve(count);
  int of_dropped_tracks = 0;
  for (size_t i = 0; i < count; ++i) {
    const StereoObservation& f = frame.features[i];
    if (!present->insert(f.id).second) {
      stats_.increment(Counter::kObsDuplicateId);
      ++result->observations_rejected;
      continue;
    }
    if (restart_limiter_.dropped(f.id)) {
      stats_.increment(Counter::kObsTrackDropped);
      ++result->observations_rejected;
      ++of_dropped_tracks;
      continue;
    }
    const std::optional<size_t> k = landmarks_.find(f.id);
    if (k) ++landmarks_.track(*k).frames;
    if (!screening_.screen(f, camera_, &stats_, result)) continue;
    StereoCandidate c;
    c.feature = f;
    if (k) {
      c.landmark = *k;
      c.via_clone = repeated_handler_.crossesRepeatedFrame(f.id);
      updates->push_back(std::move(c));
    } else {
      initializations->push_back(std::move(c));
    }
  }
  return of_dropped_tracks;
}

void VislamEstimator::endAbsentTracks(const FeatureFrame& frame,
                                      const std::unordered_set<uint32_t>& present,
                                      std::vector<StereoCandidate>* updates, FeedResult* result) {
  // Before the update: a smaller state is cheaper. An empty message ends no track.
  const std::vector<bool> ended = landmarks_.endedTracks(present, frame.features.empty());
  if (std::find(ended.begin(), ended.end(), true) == ended.end()) return;
  std::vector<size_t> map_index;
  map_index.reserve(updates->size());
  for (const StereoCandidate& c : *updates)
    map_index.push_back(landmarks_.track(c.landmark).map_index);
  result->landmarks_marginalized += landmarks_.endTracks(ended, &state_, &stats_);
  for (size_t i = 0; i < updates->size(); ++i) {
    (*updates)[i].landmark = *landmarks_.find(landmarks_.map()[map_index[i]].id);
  }
}

bool VislamEstimator::consumeJumpTest() {
  if (options_->landmarks.jump_threshold_px <= 0.0) return false;
  if (!jump_test_paused_) return true;
  jump_test_paused_ = false;
  return false;
}

size_t VislamEstimator::twistSpeedSamples() const {
  const size_t samples = propagator_.speedSamples();
  return samples - std::min<size_t>(samples, stats_.get(Counter::kTwistAtRest));
}

double VislamEstimator::meanTwistSpeed() const {
  // The samples held at rest leave the count; their speed, at most standstill/max_twist_speed
  // each (0 for a wheel odometry), stays in the sum.
  const size_t moving = twistSpeedSamples();
  return moving > 0 ? propagator_.meanSpeed() * static_cast<double>(propagator_.speedSamples()) /
                          static_cast<double>(moving)
                    : 0.0;
}

void VislamEstimator::checkTwistAtRest(const TwistData& twist) {
  const StandstillOptions& o = options_->standstill;
  if (options_->mode != EstimatorMode::kSlam || !o.enabled) return;
  // At rest a wheel odometry reads 0, and a gyro its bias within its noise.
  static const double kThreshold = chiSquareQuantile(0.999, 6);
  if (twist.v_imu.norm() <= o.max_twist_speed &&
      distanceFromRest2(propagator_, twist, state_) <= kThreshold) {
    return;
  }
  twist_moved_ = true;
  holding_still_ = false;  // the twist shows motion: the hold ends with this sample
}

void VislamEstimator::measureGyroBiasAtRest(const TwistData& twist, double sample_period) {
  stats_.increment(Counter::kTwistAtRest);
  const std::optional<UpdateStatus> status =
      updateGyroBiasAtRest(propagator_, twist, sample_period, &state_);
  if (status && *status != UpdateStatus::kApplied) stats_.increment(Counter::kUpdateNonFinite);
}

void VislamEstimator::processFrame(const FeatureFrame& frame, bool view_repeated,
                                   FeedResult* result) {
  size_t count = frame.features.size();
  const int cap = options_->limits.max_features_per_frame;
  if (cap > 0 && count > static_cast<size_t>(cap)) {
    stats_.increment(Counter::kFrameCapped);
    std::ostringstream why;
    why << "frame with " << count << " features capped to limits/max_features_per_frame = " << cap;
    result->message = why.str();
    result->observations_rejected += static_cast<int>(count) - cap;
    count = cap;
  }
  std::unordered_set<uint32_t> present;
  std::vector<StereoCandidate> updates, initializations;
  const int of_dropped_tracks =
      collectCandidates(frame, count, &present, &updates, &initializations, result);
  endAbsentTracks(frame, present, &updates, result);

  // Joint update with the re-observed landmarks, then new landmarks from the corrected pose.
  StereoUpdateOutcome outcome;
  if (view_repeated) {
    stats_.increment(Counter::kFrameAtRest);
    stats_.increment(Counter::kObsAtRest, updates.size());
  } else if (!updates.empty()) {
    if (options_->landmarks.inverse_depth_correction) {
      state_.inverse_depth_cam_T_imu = camera_.camTImu();
    }
    outcome = updater_.update(&updates, consumeJumpTest(), nominal_calibration_, &camera_, &state_,
                              &landmarks_, &stats_, result);
    limitRestarts(&outcome);
    landmarks_.apply(outcome.leaving, &state_, &stats_, result);
    speed_monitor_.add(outcome.speed_scale);
    disparity_monitor_.add(outcome.disparity_offset);
    countObservedSpeedError();
    countShownDisparityOffset();
  }
  countShownTiltError();
  // Tracks through the last repeated frame have been seen from the clone: from now on they
  // report their landmark moved by the clone-to-now motion.
  if (repeated_handler_.pending()) {
    repeated_handler_.shiftCrossingTracks(camera_, &state_, &landmarks_, &stats_, result);
  }
  for (const std::vector<StereoCandidate>* starts : {&outcome.restart_from, &initializations}) {
    for (const StereoCandidate& c : *starts) {
      landmarks_.initialize(c.feature, frame.stamp, c.reuse_map_index, camera_, &state_, &stats_,
                            result);
    }
  }
  landmarks_.syncMap(state_, time_);
  restart_limiter_.endFrame(present, frame.features.empty());
  // The previous frame's pose for the next frame's differenced observations.
  if (options_->noise.pixel_correlation > 0.0) state_.clonePose();
  // A dropped track's observation is one that disagreed: a frame of mostly such tracks is a
  // frame whose observations are mostly gated.
  checkHealth(static_cast<int>(updates.size()) + of_dropped_tracks,
              outcome.disagreeing + of_dropped_tracks, result);
}

void VislamEstimator::limitRestarts(StereoUpdateOutcome* outcome) {
  // Mapping: the landmarks restart as the dead-reckoned pose drifts, and none moves the pose.
  if (options_->mode != EstimatorMode::kSlam) return;
  std::unordered_set<uint32_t> dropped;
  for (const std::vector<size_t>* leaving : {&outcome->leaving.restart, &outcome->leaving.jumped}) {
    for (size_t k : *leaving) {
      const uint32_t id = landmarks_.mapEntry(k).id;
      if (restart_limiter_.recordRestart(id)) dropped.insert(id);
    }
  }
  if (dropped.empty()) return;
  stats_.increment(Counter::kLandmarkTrackDropped, dropped.size());
  std::vector<StereoCandidate>& starts = outcome->restart_from;
  starts.erase(
      std::remove_if(starts.begin(), starts.end(),
                     [&](const StereoCandidate& c) { return dropped.count(c.feature.id); }),
      starts.end());
}

void VislamEstimator::countObservedSpeedError() {
  const VislamOptions& o = *options_;
  if (!o.noise.count_observed_speed_error || o.mode != EstimatorMode::kSlam ||
      !countsSpeedScale(o)) {
    return;
  }
  countShownError(speed_monitor_, o.noise.twist_speed_scale_sigma, twistSpeedScaleSigma(),
                  state_.layout().speedScaleRow());
}

void VislamEstimator::countShownDisparityOffset() {
  const VislamOptions& o = *options_;
  // In mapping mode the innovations also hold the uncorrected pose's drift: no reading there.
  if (!o.intrinsic.count_shown_disparity_offset || o.mode != EstimatorMode::kSlam ||
      !countsDisparityOffset(o)) {
    return;
  }
  disparity_offset_counted_shown_ =
      std::max(disparity_offset_counted_shown_,
               countShownError(disparity_monitor_, o.intrinsic.disparity_offset_counted_sigma,
                               disparityOffsetSigma(), state_.layout().disparityRow()));
}

double VislamEstimator::countShownError(const ConsiderErrorMonitor& monitor, double configured,
                                        double counted, int row) {
  // Only once the evidence is fine enough, and only ever up: real tracks, correlated from frame
  // to frame, scatter the early estimate by several of its white sigmas.
  if (!(monitor.whiteSigma() <= kShownErrorEvidence * configured)) return 0.0;
  const double shown = std::abs(monitor.error()) - kShownErrorSigmas * monitor.whiteSigma();
  if (!(shown > (1.0 + kShownErrorTolerance) * counted)) return 0.0;
  state_.setConsiderSigma(row, shown);
  return shown;
}

void VislamEstimator::countShownTiltError() {
  const VislamOptions& o = *options_;
  const StateLayout& layout = state_.layout();
  if (layout.tilt_dim == 0) return;
  // The road's true tilt lies within kShownTiltErrorSigmas of its prior (86 % of the draws of the
  // two axes): an estimate beyond that errs by at least the excess, along its own direction.
  const Eigen::Vector2d& road_tilt = state_.road_tilt_world;
  const double excess = road_tilt.norm() - kShownTiltErrorSigmas * o.vehicle.tilt_sigma;
  if (!(excess > 0.0)) return;
  shown_tilt_error_ = std::max(shown_tilt_error_, excess);
  // Without gravity nothing but the prior knows the world's tilt; with it the tilt is measured.
  if (!o.vehicle.count_shown_tilt_error || !carriesReportedCovariance(o) ||
      stats_.get(Counter::kGravityUpdate) > 0) {
    return;
  }
  const Eigen::VectorXd direction = road_tilt.normalized();
  const double reported = direction.dot(
      state_.reportedCovariance().block<2, 2>(layout.tiltRow(), layout.tiltRow()) * direction);
  const double floor = excess * (1.0 - kShownErrorTolerance);
  if (reported < floor * floor) {
    state_.setReportedVarianceAlong(layout.tiltRow(), 2, direction, excess * excess);
  }
}

// ---------------------------------------------------------------------------------------------
// Health
// ---------------------------------------------------------------------------------------------

double VislamEstimator::positionSigma() const {
  // Of the position in world axes (the internal rho also carries rotation error x distance).
  const Matrix6d linear = linearWorldPoseCovariance(
      state_.poseCovariance(state_.covarianceCount() - 1), worldTImu().translation());
  return std::sqrt(linear.diagonal().head<3>().maxCoeff());
}

void VislamEstimator::checkHealth(int candidates, int disagreeing, FeedResult* result) {
  std::string why;
  if (!health_.diverged(candidates, disagreeing, positionSigma(), &why)) return;
  stats_.increment(Counter::kDivergenceRecovery);
  landmarks_.remove(std::vector<bool>(landmarks_.activeCount(), true),
                    /*count_as_marginalized=*/true, &state_, &stats_);
  if (options_->health.divergence_policy == DivergencePolicy::kResetFilter) {
    state_.bias.setZero();
    resetToPrior();
    result->message = "divergence: " + why + "; filter restarted at the current pose";
  } else {
    // Keep the pose and bias estimates; their covariance must stay finite and bounded.
    if (!state_.covariance().allFinite() ||
        !(positionSigma() <= options_->health.max_position_sigma)) {
      resetToPrior();
    }
    result->message = "divergence: " + why + "; landmarks dropped from the state";
  }
}

// ---------------------------------------------------------------------------------------------
// Outputs
// ---------------------------------------------------------------------------------------------

Eigen::Isometry3d VislamEstimator::worldTImu() const {
  return Eigen::Isometry3d(se3::inverse(state_.imu_T_world));
}

Matrix6d VislamEstimator::poseCovarianceWorld() const {
  return reportedWorldPoseCovariance(state_.poseCovariance(state_.covarianceCount() - 1),
                                     worldTImu().translation());
}

TwistData VislamEstimator::correctedTwist() const {
  TwistData t = held_twist_;
  const Vector6d u = propagator_.correctedTwist(state_, held_twist_);
  t.v_imu = u.head<3>();
  t.w_imu = u.tail<3>();
  return t;
}

Matrix6d VislamEstimator::correctedTwistCovariance() const {
  return propagator_.sampleCovariance(state_, held_twist_);
}

Eigen::VectorXd VislamEstimator::reportedAuxSigmas(int row, int dim) const {
  const Eigen::MatrixXd aux = state_.auxCovariance(state_.covarianceCount() - 1);
  return aux.diagonal().segment(row - StateLayout::kPoseDim, dim).cwiseSqrt();
}

double VislamEstimator::twistSpeedScaleSigma() const {
  const StateLayout& layout = state_.layout();
  return layout.speed_scale_dim == 0 ? 0.0 : reportedAuxSigmas(layout.speedScaleRow(), 1)(0);
}

double VislamEstimator::baselineScaleSigma() const {
  const int row = state_.layout().scaleRow();
  return state_.layout().scale_dim > 0 ? std::sqrt(state_.covariance()(row, row)) : 0.0;
}

double VislamEstimator::levelTiltDegrees() const { return tiltDegrees(state_.gravity_level_world); }

Eigen::Vector3d VislamEstimator::accelBiasSigma() const {
  const StateLayout& layout = state_.layout();
  if (layout.gravity_dim == 0) return Eigen::Vector3d::Zero();
  return reportedAuxSigmas(layout.accelBiasRow(), 3);
}

double VislamEstimator::roadTiltDegrees() const { return tiltDegrees(state_.road_tilt_world); }

double VislamEstimator::roadTiltErrorShownDegrees() const {
  return shown_tilt_error_ * 180.0 / M_PI;
}

double VislamEstimator::disparityOffsetSigma() const {
  const StateLayout& layout = state_.layout();
  return layout.disparity_dim == 0 ? 0.0 : reportedAuxSigmas(layout.disparityRow(), 1)(0);
}

}  // namespace ekf_vislam
