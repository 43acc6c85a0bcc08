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

// Time: feedTwist(t) predicts from the filter time to t with that twist (the twist sample k+1
// drives [t_k, t_k+1], which fits the data best) and holds it; feedFeatures(t) predicts to t with
// the held twist, then initializes new ids, updates with re-observed ones and marginalizes ids
// that are absent (their final estimate stays in the map). Feed measurements in stamp order
// (MeasurementSequencer does that for live input).
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/repeated_frame_detector.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace ekf_vislam {

/// What one feed call did.
struct FeedResult {
  bool accepted = true;           ///< false: the whole message was rejected (see message)
  std::string message;            ///< one line when something was rejected or repaired
  int observations_updated = 0;   ///< used in the EKF update
  int observations_rejected = 0;  ///< dropped, for any reason (see stats for reasons)
  int landmarks_initialized = 0;
  int landmarks_marginalized = 0;
  int landmarks_shifted = 0;  ///< moved for a repeated frame (limits/repeated_frames: shift)
};

class VislamEstimator {
 public:
  explicit VislamEstimator(const VislamOptions& options);

  const VislamOptions& options() const { return options_; }

  /// Sets the stereo calibration. Invalid calibration is refused (returns false, *error says
  /// why); the previous calibration, if any, stays. Prediction never needs calibration.
  bool setCalibration(const StereoCalibration& calibration, std::string* error = nullptr);
  bool hasCalibration() const { return has_calibration_; }
  const StereoCalibration& calibration() const { return camera_.calibration(); }

  FeedResult feedTwist(const TwistData& twist);
  FeedResult feedFeatures(const FeatureFrame& frame);

  /// Back to the state before the first message (pose identity, prior covariance, empty map).
  /// Calibration and statistics are kept.
  void reset();

  /// True once the first twist has set the time origin.
  bool initialized() const { return initialized_; }
  /// Filter time (stamp of the last processed measurement), seconds.
  double time() const { return time_; }

  Eigen::Isometry3d worldTImu() const;
  /// Covariance of [position; rotation] of world_T_imu, errors expressed in world axes
  /// (delta p_world, delta theta_world), ROS order (x, y, z, rot x, rot y, rot z).
  Matrix6d poseCovarianceWorld() const;
  /// Latest twist with the estimated bias removed, and the covariance of [v; w] (measurement
  /// noise density over the last step plus bias covariance).
  TwistData correctedTwist() const;
  Matrix6d correctedTwistCovariance() const;
  /// Estimated bias [v; w] (zeros for components not estimated).
  Vector6d twistBias() const;
  /// Estimated rotation from the twist's measurement frame to the IMU frame (identity when not
  /// estimated).
  const Eigen::Matrix3d& twistRotation() const { return imu_R_twist_; }
  /// Estimated stereo disparity offset, px: measured uL - uR minus the true disparity (0 when not
  /// estimated), and its standard deviation.
  double disparityOffset() const { return disparity_offset_; }
  double disparityOffsetSigma() const;
  /// Estimated stereo baseline scale (true baseline / calibrated baseline; 1 when not estimated)
  /// and the standard deviation of that ratio.
  double baselineScale() const { return 1.0 + baseline_scale_error_; }
  double baselineScaleSigma() const;

  /// Every landmark ever initialized (active ones carry their current estimate).
  const std::vector<LandmarkEstimate>& landmarks() const { return map_; }
  size_t activeLandmarkCount() const { return blocks_.size(); }
  /// Dimension of the filter state (6 + bias + 3 x active landmarks).
  int stateDimension() const { return dim_; }
  const EstimatorStats& stats() const { return stats_; }

  /// Full covariance of the state (tests and consistency checks), order: pose, bias, landmarks.
  Eigen::MatrixXd stateCovariance() const { return sigma_.topLeftCorner(dim_, dim_); }

 private:
  struct Candidate;  // one observation being processed
  /// A landmark block of the state: rows landmarkRow(k) .. +3 for block k.
  struct StateBlock {
    size_t map_index = 0;
    bool tracking = true;  ///< false: its track ended but the block stays (keep_all_in_state)
    int consecutive_gated = 0;  ///< frames in a row whose observation failed the gate
    int frames = 1;  ///< frames its track has been seen in since this landmark started
    int frames_absent = 0;  ///< consecutive non-empty frames its id was missing from
    /// Residual [uL, v] (px) left after the last update that used it: the reference of the next
    /// frame's track-jump test. Valid only when has_flow_reference.
    Eigen::Vector2d flow_residual = Eigen::Vector2d::Zero();
    Eigen::Matrix<double, 2, 3> flow_H_landmark = Eigen::Matrix<double, 2, 3>::Zero();
    bool has_flow_reference = false;
  };

  void initializeState();
  /// Predicts from the filter time to `stamp` with `twist`; twist_stamp is the time of the last
  /// twist (a gap beyond limits/max_twist_gap follows the gap policy, once per gap).
  void advanceTo(double stamp, const TwistData& twist, double twist_stamp, FeedResult* result);
  double positionSigma() const;
  void predict(double dt, const TwistData& twist, double noise_scale);
  void processFrame(const FeatureFrame& frame, FeedResult* result);
  /// Repeated frame (policy shift): keeps a copy of the pose at its stamp (the clone), remembers
  /// the tracks that run through it and starts the tracks that are new in it (new_tracks: indices
  /// into frame.features); its other observations are copies and are not used.
  void holdRepeatedFrame(const FeatureFrame& frame, const std::vector<size_t>& new_tracks,
                         FeedResult* result);
  /// Copies the current pose (mean and covariance rows) into the clone.
  void clonePose();
  /// Moves each landmark of a track through the last repeated frame by the motion from the
  /// clone to now, p <- world_T_imu imu_T_world(clone) p, with its covariance through the exact
  /// Jacobian: from now on its track reports that point (doc/estimator.md, "Repeated frames").
  void shiftCrossingTracks(FeedResult* result);
  /// Screens one observation (finite, in both images, rows agree, positive disparity): false
  /// with the reason counted.
  bool screenObservation(const StereoObservation& f, FeedResult* result);
  void update(std::vector<Candidate>* candidates, std::vector<Candidate>* reinitialize,
              FeedResult* result);
  bool initializeLandmark(const Candidate& candidate, double stamp, FeedResult* result);
  /// Flags the candidates whose track jumped (options jump_threshold_*; track_jump_detector.h).
  void detectJumps(std::vector<Candidate>* candidates);
  /// Residual [uL, v] of observation f against block's landmark at the current state: the
  /// reference of the next frame's jump test.
  void setFlowReference(size_t block, const StereoObservation& f);
  /// Removes the blocks whose flag is set (their final estimate stays in the map).
  void removeBlocks(const std::vector<bool>& remove, bool count_as_marginalized = true);
  void ensureCapacity(int dim);
  void syncBlocksToMap();
  /// Mean and covariance of one block into its map entry.
  void syncBlockToMap(size_t block);
  /// Covariance of the additive error of block k's landmark (dp = xi - p^ phi in SLAM mode).
  Eigen::Matrix3d landmarkCovariance(size_t block) const;
  void checkHealth(int candidates, int gated, FeedResult* result);
  void recoverFromDivergence(const std::string& why, FeedResult* result);
  void setPriorCovariance();
  /// States the prediction moves besides the pose: bias, R_m, calibration.
  int auxDim() const { return bias_dim_ + rotation_dim_ + calibrationDim(); }
  /// The pose clone (6 rows, policy shift in SLAM mode) follows the auxiliary states; the
  /// prediction leaves it alone.
  int cloneRow() const { return kPoseDim + auxDim(); }
  /// Rows before the first landmark: pose, auxiliary states, clone.
  int headDim() const { return kPoseDim + auxDim() + clone_dim_; }
  /// Stereo calibration states (disparity offset, then baseline scale) start at this row.
  int calibrationRow() const { return kPoseDim + bias_dim_ + rotation_dim_; }
  int calibrationDim() const { return disparity_dim_ + scale_dim_; }
  int disparityRow() const { return calibrationRow(); }
  int scaleRow() const { return calibrationRow() + disparity_dim_; }
  /// camera_ from the nominal calibration with the baseline scaled by the current estimate.
  void applyBaselineScale();
  int landmarkRow(size_t block) const { return headDim() + 3 * static_cast<int>(block); }
  Vector6d biasVector() const;
  /// u_true = R_m (u_measured - b) for the current estimates.
  Vector6d trueTwist(const TwistData& twist) const;
  /// Per-component factor of the vehicle prior on u = [v; w] (1 where there is none).
  Vector6d velocityPriorGain(const TwistData& twist) const;
  /// Noise density of the corrected twist in the IMU frame (process noise W = density * tau):
  /// from the message's covariance when it has one (noise/use_message_covariance), else from
  /// noise/linear_velocity_noise and angular_velocity_noise.
  Matrix6d twistNoiseDensity(const TwistData& twist) const;
  bool usesMessageCovariance(const TwistData& twist) const;
  /// The message's per-sample covariance in the IMU frame times the sample period.
  Matrix6d messageTwistDensity(const TwistData& twist) const;

  static constexpr int kPoseDim = 6;

  VislamOptions options_;
  StereoCamera camera_;
  bool has_calibration_ = false;
  int rows_per_observation_ = 3;
  Eigen::MatrixXd observation_selector_;  ///< observationSelector(merge_stereo_rows): rows x 4
  double gate_threshold_ = 0.0;
  double restart_threshold_ = 0.0;  ///< chi-square 0.9999: gross disagreement (track jumped)
  std::vector<int> bias_components_;  ///< entries of u = [v; w] whose bias is estimated

  bool initialized_ = false;
  double time_ = 0.0;
  double last_twist_stamp_ = 0.0;
  double last_twist_dt_ = 0.1;
  bool in_twist_gap_ = false;
  bool has_frame_ = false;
  double last_frame_stamp_ = 0.0;
  TwistData held_twist_;
  RepeatedFrameDetector repeated_frames_;
  /// Set by a prediction across a twist gap: the next frame's pose error is too large for the
  /// linearized common-motion fit of the jump test, which is skipped once.
  bool jump_test_paused_ = false;

  // State.
  Eigen::Matrix4d imu_T_world_ = Eigen::Matrix4d::Identity();
  /// Pose at the last repeated frame (the clone). Its tracks report, at the next frame, where
  /// their landmarks appeared from this pose; its error has state rows when clone_dim_ is 6.
  Eigen::Matrix4d imu_T_world_clone_ = Eigen::Matrix4d::Identity();
  int clone_dim_ = 0;
  std::unordered_set<uint32_t> crossing_ids_;  ///< tracks through the last repeated frame
  Eigen::VectorXd bias_;     ///< estimated bias components (size bias_dim_)
  int bias_dim_ = 0;
  Eigen::Matrix3d imu_R_twist_ = Eigen::Matrix3d::Identity();  ///< R_m
  int rotation_dim_ = 0;     ///< 3 when R_m is estimated (state rows after the bias)
  double disparity_offset_ = 0.0;  ///< px, measured minus true disparity
  int disparity_dim_ = 0;    ///< 1 when it is estimated (state row after R_m)
  double baseline_scale_error_ = 0.0;  ///< beta: baseline = calibrated baseline x (1 + beta)
  int scale_dim_ = 0;        ///< 1 when beta is estimated (row after the disparity offset)
  StereoCalibration nominal_calibration_;
  int dim_ = 0;              ///< active state dimension
  Eigen::VectorXd p_world_;  ///< landmark means at their state rows (capacity sized)
  Eigen::MatrixXd sigma_;    ///< capacity >= dim_; only the top-left dim_ x dim_ block is live
  std::vector<StateBlock> blocks_;
  std::unordered_map<uint32_t, size_t> tracking_;  ///< tracked id -> block
  std::vector<LandmarkEstimate> map_;
  int consecutive_rejected_frames_ = 0;

  EstimatorStats stats_;
};

}  // namespace ekf_vislam
