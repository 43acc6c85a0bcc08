// Every tunable of the estimator, nested by YAML group, and its key table: one parser, one
// validator and one description from a ParameterSource. Keys and documentation:
// config/default.yaml. No ROS.
#pragma once

#include "ekf_vislam/core/option_table.h"
#include "ekf_vislam/core/parameter_source.h"

#include <string>
#include <vector>

namespace ekf_vislam {

enum class EstimatorMode {
  kDeadReckoning,  ///< prediction only; features ignored
  kMapping,        ///< landmarks updated on the predicted poses; the pose is not corrected
  kSlam,           ///< joint pose + landmark update
};

/// "deadreckoning", "mapping", "slam".
const char* modeName(EstimatorMode mode);
bool parseMode(const std::string& name, EstimatorMode* mode);

/// What to do with a feature frame that repeats the previous one (repeated_frame_detector.h).
enum class RepeatedFramePolicy {
  kUse,    ///< process it like any frame
  kSkip,   ///< predict to its stamp, do not use its observations (its tracks stay alive)
  kShift,  ///< start its new tracks, clone the pose; at the next frame update its other tracks
           ///< against the clone, then move their landmarks by the clone-to-now motion (the
           ///< course files' tracks through a repeated frame lag by its motion, doc/estimator.md)
};

/// What to do when twist messages stop for longer than limits/max_twist_gap.
enum class GapPolicy {
  kPredict,  ///< predict across the gap with the last twist and process noise x gap_noise_scale
  kReset,    ///< reset the filter (pose restarts at identity, map is kept)
};

/// What to do when the filter diverges (health/ checks).
enum class DivergencePolicy {
  kResetLandmarks,  ///< marginalize every active landmark; keep the pose and bias (their
                    ///< covariance back to the prior only if it is non-finite or beyond bounds)
  kResetFilter,     ///< restart the filter at the current pose estimate with the prior covariance
};

/// noise/: measurement and process noise.
struct NoiseOptions {
  double pixel_sigma = 2.0;  ///< px, std of each image coordinate
  /// Correlation of a track's pixel error from one observation to the next (AR(1) along the
  /// track, stationary std pixel_sigma); 0: white. Consecutive observations are differenced
  /// (stereo_updater.h).
  double pixel_correlation = 0.0;
  bool merge_stereo_rows = true;  ///< observe [uL, (vL+vR)/2, uR] (3 rows) instead of 4
  /// px/sqrt(s): a track's pixel error as a random walk of this rate; every active landmark's
  /// error then walks across its camera ray by the rate times depth / focal length
  /// (landmark_drift.h). 0: landmarks are fixed points.
  double track_random_walk = 0.0;
  double linear_velocity_noise = 0.10;    ///< m/s/sqrt(Hz): W_v = sigma^2 * tau
  double angular_velocity_noise = 0.015;  ///< rad/s/sqrt(Hz): W_w = sigma^2 * tau
  /// A twist message with a non-zero covariance (TwistWithCovarianceStamped, Odometry) supplies
  /// its own noise; all-zero covariances fall back to the two densities above.
  bool use_message_covariance = true;
  /// Estimate the twist's white noise online from the samples themselves (their second
  /// differences, twist_noise_estimator.h) over the last twist_noise_window samples; the two
  /// densities above are used until twist_noise_min_samples have arrived.
  bool estimate_twist_noise = true;
  int twist_noise_window = 300;     ///< samples
  int twist_noise_min_samples = 5;  ///< samples
  /// Report a covariance that counts a track's observations at their effective number: the
  /// correlation rho of the tracks' residuals from frame to frame is estimated online
  /// (track_correlation_estimator.h), and the reported covariance (not the gains) takes the
  /// observation noise pixel_sigma^2 (1 + rho) / (1 - rho) (state_helper::update).
  bool report_track_correlation = true;
  /// Relative sigma of a constant error of the twist's speed (a wheel radius), counted where the
  /// speed scale is not estimated (countsSpeedScale): the reported covariance takes in the pose
  /// error it would cause, the estimate does not change. 0: not counted.
  double twist_speed_scale_sigma = 0.01;
  /// In SLAM mode, the counted speed error grows to the one the observations show when that is
  /// larger (ConsiderErrorMonitor: their innovations projected on the scale's sensitivity, less
  /// two of its white-noise sigmas, read once that sigma is a quarter of
  /// twist_speed_scale_sigma), and never shrinks. The estimate does not change.
  bool count_observed_speed_error = true;
  int track_correlation_window = 2000;  ///< residual pairs the estimate covers
  double track_correlation_max = 0.98;  ///< cap of the estimate (variance factor <= 99)
};

/// prior/: initial pose uncertainty (the world is the first IMU pose).
struct PriorOptions {
  double position_sigma = 1e-3;  ///< m
  double rotation_sigma = 1e-3;  ///< rad
};

/// bias/: twist bias states (random walks).
struct BiasOptions {
  bool estimate_gyro_bias = true;
  double gyro_prior_sigma = 0.02;  ///< rad/s
  double gyro_random_walk = 1e-4;  ///< rad/s/sqrt(s)
  bool estimate_velocity_bias = false;
  double velocity_prior_sigma = 0.1;   ///< m/s
  double velocity_random_walk = 1e-3;  ///< m/s/sqrt(s)
  bool estimate_speed_scale = false;
  double speed_scale_prior_sigma = 0.05;  ///< relative
  double speed_scale_random_walk = 0.0;   ///< 1/sqrt(s)
};

/// extrinsic/: the rotation R_m between the frame the twist is measured in and the IMU frame
/// that cam_T_imu refers to (u_true = R_m (u_measured - b)). Off by default: seen only through
/// the agreement of the tracks with the twist, it takes up the tracks' systematic drift.
struct ExtrinsicOptions {
  bool estimate_twist_rotation = false;
  double twist_rotation_prior_sigma = 0.05;  ///< rad
  double twist_rotation_random_walk = 0.0;   ///< rad/sqrt(s)
  /// s: images stamped t were taken at t + camera_time_offset on the twist's clock (negative for
  /// a camera whose stamps lag, e.g. stamped on arrival). Applied by EstimatorRunner::push.
  double camera_time_offset = 0.0;
};

/// intrinsic/: stereo calibration states.
struct IntrinsicOptions {
  /// A constant offset of the measured stereo disparity (uL - uR = true + offset), e.g. from a
  /// right principal point that is off by a fraction of a pixel. It biases every triangulated
  /// depth and with it the scale of the trajectory. Off by default: it is seen only through
  /// depth-against-motion agreement, so it absorbs the tracks' correlated errors instead
  /// (doc/experiments.md, 2026-11-24).
  bool estimate_disparity_offset = false;
  double disparity_offset_prior_sigma = 1.0;  ///< px
  double disparity_offset_random_walk = 0.0;  ///< px/sqrt(s)
  /// Where the offset is not estimated: its standard deviation counted in the reported covariance
  /// (a consider parameter), px; the estimate does not change. 0: not counted.
  double disparity_offset_counted_sigma = 0.1;
  /// In SLAM mode, the counted offset grows to the one the observations show when that is larger
  /// (ConsiderErrorMonitor: their innovations projected on the offset's sensitivity, less two of
  /// its white-noise sigmas, read once that sigma is a quarter of disparity_offset_counted_sigma),
  /// and never shrinks. The estimate does not change.
  bool count_shown_disparity_offset = true;
  /// A scale factor of the stereo baseline (every triangulated depth scales with it), made
  /// observable by the twist's speed.
  bool estimate_baseline_scale = false;
  double baseline_scale_prior_sigma = 0.05;  ///< relative (0.05 = 5 %)
  double baseline_scale_random_walk = 0.0;   ///< 1/sqrt(s)
};

/// track_drift/: a common rate at which the feature tracks turn away from their points. Tracks
/// that follow a point from frame to frame accumulate error (the KITTI tracks drift 0.02-0.1 px
/// per frame, doc/experiments.md): an observation of age a (s since its landmark started) shows
/// the point turned by exp(a w^) about the IMU origin (IMU axes). Off by default: on the KITTI
/// tracks the drift depends on the image position, the parallax of the translation makes w
/// observable, and the fitted common rate bends the trajectory.
struct TrackDriftOptions {
  bool estimate_rate = false;
  double rate_prior_sigma = 1e-3;  ///< rad/s, each IMU axis
  double rate_random_walk = 0.0;   ///< rad/s/sqrt(s)
};

/// vehicle/: ground-vehicle priors. The measured lateral (y) and vertical (z) velocity (IMU frame,
/// x forward) is fused with a zero-mean prior of its std before it drives the prediction (0 = no
/// prior on that axis). The vehicle's tilt (roll and pitch against the world's horizontal plane,
/// the first pose being level) follows the road: a Gauss-Markov process over the distance
/// travelled, with the body's own tilt on its suspension about it (doc/estimator.md, "Road
/// tilt"). tilt_sigma 0 = no tilt prior. With count_shown_tilt_error (SLAM, reported covariance,
/// no accelerometer update yet), a road tilt estimated beyond 2 tilt_sigma shows the excess as a
/// tilt error at least that large, and the reported covariance's tilt along it is raised to it
/// when smaller, with what it correlates; the estimate is unchanged.
struct VehicleOptions {
  double lateral_velocity_sigma = 0.1;       ///< m/s
  double vertical_velocity_sigma = 0.1;      ///< m/s
  double tilt_sigma = 0.05;                  ///< rad, std of the road's tilt from the start's
  double tilt_correlation_distance = 200.0;  ///< m, over which the road's tilt decorrelates
  double body_tilt_sigma = 0.01;             ///< rad, the body's tilt about the road's
  double tilt_update_period = 1.0;           ///< s between two tilt pseudo-observations
  bool count_shown_tilt_error = true;
};

/// gravity/: the accelerometer (sensor_msgs/Imu linear_acceleration) holds roll and pitch against
/// gravity in SLAM mode. Over each window of twist samples (window s at least) the mean specific
/// force, less the acceleration the twist shows (its velocity change and the gyro's rotation), is
/// g R^T up + b_a: up the gravity's up axis in world axes (the world is the first pose, whose
/// tilt against gravity is a state of level_sigma prior), b_a the accelerometer bias (a state).
/// The accelerometer's white noise comes from the message covariance or is estimated online from
/// its samples (as the twist's); accel_noise_density until then. Without accelerometer samples
/// the two states stay at their prior and nothing else changes (doc/estimator.md, Gravity).
struct GravityOptions {
  bool enabled = true;
  double window = 1.0;                   ///< s of twist samples per update (at least)
  double magnitude = 9.80665;            ///< m/s^2
  double level_sigma = 0.2;              ///< rad, prior of the first pose's tilt against gravity
  double accel_bias_sigma = 0.1;         ///< m/s^2, prior of each axis of the bias
  double accel_bias_random_walk = 1e-3;  ///< m/s^2/sqrt(s)
  double accel_noise_density = 0.05;     ///< m/s^2/sqrt(Hz), until the online estimate is ready
};

/// landmarks/: initialization, gating and the life cycle of landmarks.
struct LandmarkOptions {
  double min_disparity_px = 1.0;     ///< smaller (or negative) disparity: not initialized
  double min_depth = 1.0;            ///< m
  double max_depth = 80.0;           ///< m
  double gating_probability = 0.95;  ///< chi-square gate (per observation)
  /// A landmark whose observations disagree grossly (beyond the chi-square 0.9999 quantile) this
  /// many frames in a row restarts from its current observation; 0 = never.
  int reinitialize_after_gated = 1;
  /// SLAM: a track whose landmark restarted (gated grossly, or the track-jump test) more than this
  /// many times is dropped until it ends: a point that moves (a car ahead) disagrees with every
  /// static prediction (restart_limiter.h). 0 = no limit.
  int max_restarts = 2;
  /// SLAM: when more than half of a frame's re-observed landmarks (8 or more; not those seen from
  /// the clone of a repeated frame, which the prediction does not reach) fail the gate, the
  /// prediction is taken to be what is wrong: the pose's process noise since the last update is
  /// widened (x4, 16, ... 1024, as the frame's capped likelihood prefers; prediction_check.h) in
  /// both covariances, and the frame is gated jointly: each observation on what the pose change
  /// they share leaves of it (counted: frame_prediction_widened, frame_gated_jointly).
  bool prediction_check = true;
  /// A landmark tracked in this many frames leaves the state (its estimate stays in the map) and
  /// its track continues as a new landmark (same id, new map entry). 0 = never.
  int max_track_length = 0;
  /// Track-jump test (track_jump_detector.h): once the pose error common to all landmarks is
  /// removed, a re-observed landmark whose frame-to-frame flow error in uL or v exceeds
  /// jump_threshold_px and jump_threshold_sigmas robust standard deviations has jumped to another
  /// point: it leaves the state and the track continues as a new landmark. 0 px = off.
  double jump_threshold_px = 0.5;
  double jump_threshold_sigmas = 3.0;
  bool keep_all_in_state = false;  ///< never marginalize (exact, O(N^2) memory)
  /// A track absent from up to this many consecutive non-empty frames keeps its landmark in the
  /// state and resumes when its id returns; after that it ends. An empty message ends no track.
  int max_track_gap = 2;
  /// At most this many tracked landmarks in the state (kept ones of ended tracks, with
  /// keep_all_in_state, do not count): a new track waits (observation_waiting) until one leaves,
  /// then starts from its observation of that frame. The update costs O(N^2 m) for N
  /// state rows and m observation rows, so this bounds the time per frame. 0 = no bound.
  int max_active = 100;
  /// Corrections move a landmark in the inverse-depth coordinates of the current camera (where
  /// the stereo observation is linear) instead of in world coordinates (FilterState).
  bool inverse_depth_correction = true;
};

/// limits/: input sanity, twist gaps and repeated frames.
struct LimitsOptions {
  double max_linear_speed = 100.0;  ///< m/s; faster twists are rejected
  double max_angular_speed = 10.0;  ///< rad/s
  double max_twist_gap = 1.0;       ///< s; longer gaps follow gap_policy
  GapPolicy gap_policy = GapPolicy::kPredict;
  double gap_noise_scale = 10.0;       ///< process noise multiplier across a gap
  double max_row_difference_px = 5.0;  ///< |vL - vR| beyond: rejected (rectified pair)
  /// A feature frame in which every track shared with the previous frame has identical
  /// coordinates (a re-published tracker result) is always counted; this says what follows.
  RepeatedFramePolicy repeated_frames = RepeatedFramePolicy::kShift;
  /// shift: standard deviation added to a moved landmark along the camera ray, relative to its
  /// distance (the move assumes equal motion over the repeated frame and the next one).
  double repeated_frame_depth_sigma = 0.1;
  int max_features_per_frame = 400;  ///< 0 = unlimited; extra features of a frame dropped
};

/// standstill/: a camera at rest (SLAM mode, StandstillDetector).
struct StandstillOptions {
  /// While the tracks and the twist show the camera at rest, the pose is held (no twist
  /// integrated, no process noise), each gyro sample measures the gyro bias (the true rate is 0),
  /// and the frames after the first one at rest do not update the filter (the same view again).
  bool enabled = true;
  /// px: at rest while 80 % of the tracks moved at most this since the rest began.
  double max_displacement_px = 0.5;
  /// m/s: at rest while every twist sample's linear velocity is at most this (a wheel odometry
  /// at rest reads 0; a velocity with noise, as the KITTI course twists', never rests).
  double max_twist_speed = 0.01;
  int min_tracks = 10;  ///< fewer shared tracks: not at rest
};

/// health/: divergence detection and recovery.
struct HealthOptions {
  double max_position_sigma = 1000.0;  ///< m; pose sigma beyond: divergence
  int max_rejected_frames = 20;        ///< consecutive frames with most observations gated
  double rejected_fraction = 0.8;      ///< "most" above
  DivergencePolicy divergence_policy = DivergencePolicy::kResetLandmarks;
};

/// Every tunable of the estimator, one nested struct per YAML group (config/default.yaml). The
/// key table (vislam_options.cc) names each key once for parsing, validation and description.
struct VislamOptions {
  EstimatorMode mode = EstimatorMode::kSlam;
  NoiseOptions noise;
  PriorOptions prior;
  BiasOptions bias;
  ExtrinsicOptions extrinsic;
  IntrinsicOptions intrinsic;
  TrackDriftOptions track_drift;
  VehicleOptions vehicle;
  GravityOptions gravity;
  LandmarkOptions landmarks;
  LimitsOptions limits;
  StandstillOptions standstill;
  HealthOptions health;

  /// Empty when every key is within its range and the keys agree; otherwise one line naming the
  /// bad key.
  std::string validate() const;
};

/// Whether an accelerometer is used: gravity/enabled, and SLAM mode (dead reckoning stays the
/// twist alone, mapping keeps the dead-reckoned poses).
inline bool usesAccelerometer(const VislamOptions& options) {
  return options.gravity.enabled && options.mode == EstimatorMode::kSlam;
}

/// Whether the filter carries a second covariance, the one it reports, beside the gains' one
/// (noise/report_track_correlation; dead reckoning has no update and carries one).
inline bool carriesReportedCovariance(const VislamOptions& options) {
  return options.noise.report_track_correlation && options.mode != EstimatorMode::kDeadReckoning;
}

/// Whether the twist's speed scale is a state the updates estimate (bias/estimate_speed_scale, SLAM
/// mode: seen through the stereo depths).
inline bool estimatesSpeedScale(const VislamOptions& options) {
  return options.bias.estimate_speed_scale && options.mode == EstimatorMode::kSlam;
}

/// Whether it is only counted (noise/twist_speed_scale_sigma > 0, not estimated): a row no update
/// moves, carried in the reported covariance (in dead reckoning's only one, which no update
/// touches), so that the reported pose takes in the speed error the filter does not correct (a
/// consider parameter); the estimate does not change. Without a reported covariance the gains
/// would estimate it: not counted there.
inline bool countsSpeedScale(const VislamOptions& options) {
  return !estimatesSpeedScale(options) && options.noise.twist_speed_scale_sigma > 0.0 &&
         (carriesReportedCovariance(options) || options.mode == EstimatorMode::kDeadReckoning);
}

/// Whether the disparity offset is only counted in the reported covariance (SLAM and mapping with
/// a reported covariance, the offset not estimated, a positive counted sigma).
inline bool countsDisparityOffset(const VislamOptions& options) {
  return !options.intrinsic.estimate_disparity_offset &&
         options.intrinsic.disparity_offset_counted_sigma > 0.0 &&
         carriesReportedCovariance(options);
}

/// Fills `options` from `source`: absent keys keep their current values; unknown enum names or
/// values of the wrong type or out of range make it return false with a message naming the key,
/// and leave `options` unchanged.
bool parseVislamOptions(const ParameterSource& source, VislamOptions* options, std::string* error);

/// The effective options, one "group: key=value ..." line per YAML group (logged at start).
std::string describeOptions(const VislamOptions& options);

/// Every key of the table ("noise/pixel_sigma", ...), with its kind and range.
std::vector<OptionKeyList::Key> vislamOptionKeys();

}  // namespace ekf_vislam
