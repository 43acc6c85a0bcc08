// EKF visual-inertial SLAM on SE(3): the estimator core. No ROS.
//
// State: pose world_T_imu (T) with a world-frame perturbation T = exp(eps^) T_mean,
// eps = [rho; phi] (translation first), optional twist bias b and rotation R_m of the twist frame
// (u_true = R_m (u_measured - b), R_m = exp(theta^) R_m_mean), and the
// landmarks that are currently tracked, each with the invariant error xi_i of right-invariant
// EKF-SLAM (Barrau & Bonnabel): p_i = exp(phi^) p_i_mean + xi_i. One joint covariance.
//
// Why not the course's body-frame error with additive landmark errors (equal to first order):
// in that form the unobservable gauge directions (global rotation and translation) depend on the
// estimates, every update moves them, and the filter gains information it does not have (pose
// NEES 25-60 instead of 6 on the synthetic drives). With the invariant error the gauge directions
// are constant, the pose block of the propagation is the identity, and the observation Jacobian
// is H_phi = 0, H_rho = -H_landmark: the filter stays consistent whatever the linearization point.
// Outputs (map covariances, pose covariance) are converted to ordinary additive errors.

// The estimator orchestrates small components: InputScreening, Propagator, VehicleTiltUpdater
// (the road tilt prior, SLAM mode), GravityUpdater (the accelerometer, SLAM mode), LandmarkManager,
// StereoUpdater (through state_helper's generic EKF operations on a FilterState),
// RepeatedFrameHandler and HealthMonitor.
//
// Time: feedTwist(t) predicts from the filter time to t with that twist (the twist sample k+1
// drives [t_k, t_k+1], which fits the data best) and holds it; feedFeatures(t) predicts to t with
// the held twist, then initializes new ids, updates with re-observed ones and marginalizes ids
// that are absent (their final estimate stays in the map). Feed measurements in stamp order
// (MeasurementSequencer does that for live input).
#pragma once

#include "ekf_vislam/core/consider_error_monitor.h"
#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/feed_result.h"
#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/gravity_updater.h"
#include "ekf_vislam/core/health_monitor.h"
#include "ekf_vislam/core/input_screening.h"
#include "ekf_vislam/core/landmark_manager.h"
#include "ekf_vislam/core/propagator.h"
#include "ekf_vislam/core/repeated_frame_detector.h"
#include "ekf_vislam/core/repeated_frame_handler.h"
#include "ekf_vislam/core/restart_limiter.h"
#include "ekf_vislam/core/standstill_detector.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/stereo_updater.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vehicle_tilt_updater.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace ekf_vislam {

class VislamEstimator {
 public:
  explicit VislamEstimator(const VislamOptions& options);

  const VislamOptions& options() const { return *options_; }

  /// Sets the stereo calibration. Invalid calibration is refused (returns false, *error says
  /// why); the previous calibration, if any, stays. Prediction never needs calibration.
  bool setCalibration(const StereoCalibration& calibration, std::string* error = nullptr);
  bool hasCalibration() const { return has_calibration_; }
  const StereoCalibration& calibration() const { return camera_.calibration(); }

  FeedResult feedTwist(const TwistData& twist);
  FeedResult feedFeatures(const FeatureFrame& frame);
  /// An accelerometer sample (IMU frame), in stamp order with the other accelerometer samples;
  /// used by the gravity update at the twists after it (gravity/, SLAM mode).
  FeedResult feedAccelerometer(const AccelerometerData& sample);

  /// Back to the state before the first message (pose identity, prior covariance, empty map).
  /// Calibration and statistics are kept.
  void reset();

  /// True once the first twist has set the time origin.
  bool initialized() const { return initialized_; }
  /// Filter time (stamp of the last processed measurement), seconds.
  double time() const { return time_; }

  Eigen::Isometry3d worldTImu() const;
  /// Covariance of [position; rotation] of world_T_imu, errors expressed in world axes
  /// (delta p_world, delta theta_world), ROS order (x, y, z, rot x, rot y, rot z): the reported
  /// one, with the spread of a large rotation uncertainty (pose_covariance.h).
  Matrix6d poseCovarianceWorld() const;
  /// Latest twist with the estimated bias removed, and the covariance of [v; w] (measurement
  /// noise density over the last step plus bias covariance).
  TwistData correctedTwist() const;
  Matrix6d correctedTwistCovariance() const;
  /// Estimated bias [v; w] (zeros for components not estimated).
  Vector6d twistBias() const { return state_.biasVector(); }
  /// Estimated scale of the twist's linear velocity (true / measured speed, bias removed; 1 when
  /// not estimated) and its standard deviation in the reported covariance (0 when not estimated).
  double twistSpeedScale() const { return 1.0 + state_.speed_scale_error; }
  double twistSpeedScaleSigma() const;
  /// The twist's speed error the camera's observations show where the scale is only counted
  /// (ConsiderErrorMonitor), and the scale (true / measured speed) it reads: 1 without evidence.
  const ConsiderErrorMonitor& speedErrorMonitor() const { return speed_monitor_; }
  double twistSpeedScaleShown() const { return 1.0 + speed_monitor_.error(); }
  /// Estimated rotation from the twist's measurement frame to the IMU frame (identity when not
  /// estimated).
  const Eigen::Matrix3d& twistRotation() const { return state_.imu_R_twist; }
  /// Estimated stereo disparity offset, px: measured uL - uR minus the true disparity (0 when not
  /// estimated), and its standard deviation in the reported covariance (the counted one,
  /// intrinsic/disparity_offset_counted_sigma, where it is only counted; 0 without the row).
  double disparityOffset() const { return state_.disparity_offset; }
  double disparityOffsetSigma() const;
  /// The disparity offset the camera's observations show where it is only counted
  /// (ConsiderErrorMonitor; px, measured minus true).
  const ConsiderErrorMonitor& disparityOffsetMonitor() const { return disparity_monitor_; }
  /// The largest counted sigma the shown offset set, px (0: it never exceeded the configured one).
  double disparityOffsetCountedShown() const { return disparity_offset_counted_shown_; }
  /// Estimated stereo baseline scale (true baseline / calibrated baseline; 1 when not estimated)
  /// and the standard deviation of that ratio.
  double baselineScale() const { return 1.0 + state_.baseline_scale_error; }
  /// Rate (rad/s, IMU axes) at which the tracks turn away from their points (track_drift/;
  /// zero when not estimated).
  const Eigen::Vector3d& trackDriftRate() const { return state_.track_drift_rate_imu; }
  double baselineScaleSigma() const;
  /// Tilt of the road under the vehicle against the first pose's level, degrees (vehicle/
  /// tilt_sigma; 0 without the road tilt in the state).
  double roadTiltDegrees() const;
  /// The largest tilt error the road tilt has shown so far, degrees: its estimate beyond twice
  /// vehicle/tilt_sigma (vehicle/count_shown_tilt_error counts it in the reported covariance; 0
  /// without the road tilt in the state).
  double roadTiltErrorShownDegrees() const;
  /// The first pose's tilt against gravity (degrees; gravity/, 0 without its states) and the
  /// estimated accelerometer bias (m/s^2, IMU axes) with its standard deviations.
  double levelTiltDegrees() const;
  const Eigen::Vector3d& accelBias() const { return state_.accel_bias_imu; }
  Eigen::Vector3d accelBiasSigma() const;
  /// Frame-to-frame correlation of the tracks' residuals (noise/report_track_correlation; 0
  /// until enough tracks were seen twice) and the factor (1 + rho) / (1 - rho) on the pixel
  /// variance of the reported covariance.
  double trackCorrelation() const { return updater_.trackCorrelation().correlation(); }
  double trackVarianceFactor() const { return updater_.trackCorrelation().varianceFactor(); }
  /// The factor the frames before its first estimate were recounted with (0: not yet).
  double trackNoiseRecountFactor() const { return updater_.trackNoiseRecountFactor(); }
  /// Where the twist travels in its own frame (yaw, pitch from x; TravelDirectionEstimator).
  const TravelDirectionEstimator& travelDirection() const { return propagator_.travelDirection(); }
  /// The twist's noise densities in use (m/s/sqrt(Hz), rad/s/sqrt(Hz): estimated online once
  /// ready, else configured), its mean forward speed (m/s) and the samples that speed covers.
  double linearNoiseDensity() const { return propagator_.linearNoiseDensity(); }
  double angularNoiseDensity() const { return propagator_.angularNoiseDensity(); }
  /// Mean forward speed (m/s) of the twist samples, those held at rest (standstill/) left out:
  /// the drive's, however long it stood; and the samples it covers.
  double meanTwistSpeed() const;
  size_t twistSpeedSamples() const;

  /// Every landmark ever initialized (active ones carry their current estimate).
  const std::vector<LandmarkEstimate>& landmarks() const { return landmarks_.map(); }
  size_t activeLandmarkCount() const { return landmarks_.activeCount(); }
  /// Dimension of the filter state (head + 3 x active landmarks).
  int stateDimension() const { return state_.dim(); }
  const EstimatorStats& stats() const { return stats_; }

  /// Full covariance of the state (tests and consistency checks), order: pose, auxiliary
  /// states, clone, landmarks.
  Eigen::MatrixXd stateCovariance() const { return state_.covariance(); }

 private:
  /// The gravity update's part of an accepted twist that moved the filter to its stamp.
  void updateGravity(const TwistData& twist);
  /// Predicts from the filter time to `stamp` with `twist`; twist_stamp is the time of the last
  /// twist (a gap beyond limits/max_twist_gap follows the gap policy, once per gap).
  void advanceTo(double stamp, const TwistData& twist, double twist_stamp, FeedResult* result);
  /// Why a feature frame cannot be used now (stamp, time origin, calibration), or nothing.
  std::optional<Counter> checkFrame(const FeatureFrame& frame, std::string* why) const;
  /// view_repeated: the camera still at rest since the last frame (standstill/): its tracks see
  /// what they saw and do not update.
  void processFrame(const FeatureFrame& frame, bool view_repeated, FeedResult* result);
  /// A twist sample that moves (a speed above standstill/max_twist_speed, or a rate beyond its
  /// noise from 0) ends a hold at once and keeps the next frame from starting one.
  void checkTwistAtRest(const TwistData& twist);
  /// At rest, the accepted twist's gyro sample measures the gyro bias (standstill/).
  void measureGyroBiasAtRest(const TwistData& twist, double sample_period);
  /// Sorts a frame's usable observations into updates (tracked ids) and initializations.
  /// Returns how many observations belong to dropped tracks (landmarks/max_restarts).
  int collectCandidates(const FeatureFrame& frame, size_t count,
                        std::unordered_set<uint32_t>* present,
                        std::vector<StereoCandidate>* updates,
                        std::vector<StereoCandidate>* initializations, FeedResult* result);
  /// Tracks absent beyond landmarks/max_track_gap leave the state; updates' indices follow.
  void endAbsentTracks(const FeatureFrame& frame, const std::unordered_set<uint32_t>& present,
                       std::vector<StereoCandidate>* updates, FeedResult* result);
  /// The jump test runs unless a twist gap paused it for this frame.
  bool consumeJumpTest();
  void checkHealth(int candidates, int disagreeing, FeedResult* result);
  /// The counted speed error follows the one the observations show
  /// (noise/count_observed_speed_error).
  void countObservedSpeedError();
  /// The counted disparity offset follows the one the observations show
  /// (intrinsic/count_shown_disparity_offset).
  void countShownDisparityOffset();
  /// Raises the counted sigma of consider row `row` (now `counted`, configured `configured`) to
  /// the error `monitor` shows, once its evidence is fine enough: the sigma set, or 0.
  double countShownError(const ConsiderErrorMonitor& monitor, double configured, double counted,
                         int row);
  /// The reported tilt takes the error the road tilt's estimate shows beyond its prior
  /// (vehicle/count_shown_tilt_error).
  void countShownTiltError();
  /// The landmarks the update restarts (or whose tracks jumped) count against their ids'
  /// restarts (landmarks/max_restarts); a track that restarted once too often is dropped and
  /// does not restart.
  void limitRestarts(StereoUpdateOutcome* outcome);
  void resetToPrior();
  StatePrior prior() const;
  // The largest position sigma of the linear world-axes covariance (the health check's).
  double positionSigma() const;
  /// Standard deviations in the reported covariance of the `dim` auxiliary-state rows from state
  /// row `row` (between the pose and the clone).
  Eigen::VectorXd reportedAuxSigmas(int row, int dim) const;
  void initializeState();

  std::shared_ptr<const VislamOptions> options_;  ///< shared by the components (copies too)
  FilterState state_;
  InputScreening screening_;
  Propagator propagator_;
  VehicleTiltUpdater tilt_updater_;
  GravityUpdater gravity_updater_;
  StereoUpdater updater_;
  LandmarkManager landmarks_;
  RepeatedFrameHandler repeated_handler_;
  RestartLimiter restart_limiter_;
  HealthMonitor health_;
  ConsiderErrorMonitor speed_monitor_;
  ConsiderErrorMonitor disparity_monitor_;
  double disparity_offset_counted_shown_ = 0.0;
  RepeatedFrameDetector repeated_frames_;
  StandstillDetector standstill_;
  /// The last frame showed the camera at rest: the pose is held until a frame shows it moved.
  bool holding_still_ = false;
  bool twist_moved_ = false;  ///< a twist since the last frame was beyond its noise from rest

  StereoCalibration nominal_calibration_;
  StereoCamera camera_;  ///< nominal calibration, baseline scaled by the current estimate
  bool has_calibration_ = false;

  bool initialized_ = false;
  double shown_tilt_error_ = 0.0;  ///< rad, the largest so far (countShownTiltError)
  double time_ = 0.0;
  double last_twist_stamp_ = 0.0;
  bool in_twist_gap_ = false;
  bool has_frame_ = false;
  double last_frame_stamp_ = 0.0;
  /// Stamp up to which the landmarks' drift (noise/track_random_walk) has been added; NaN: none.
  double drift_stamp_ = std::numeric_limits<double>::quiet_NaN();
  TwistData held_twist_;
  /// Set by a prediction across a twist gap: the next frame's pose error is too large for the
  /// linearized common-motion fit of the jump test, which is skipped once.
  bool jump_test_paused_ = false;

  EstimatorStats stats_;
};

}  // namespace ekf_vislam
