// The EKF state: named variables (pose, twist bias, twist speed scale, twist rotation, stereo
// calibration, track drift rate, road tilt, gravity, pose clone, landmarks), their means and one
// joint covariance. No ROS.
//
// Error definitions (doc/estimator.md): pose world_T_imu = exp(eps^) world_T_imu_mean with
// eps = [rho; phi] (world frame, translation first); bias b_true = b_mean + db; speed scale
// k_true = k_mean + dk; twist rotation R_m = exp(theta^) R_m_mean; disparity offset,
// baseline-scale error and track drift rate additive; road tilt additive; the clone like the pose;
// landmark i: p_i = exp(phi^) p_i_mean + xi_i in SLAM mode (right-invariant error),
// p_i = p_i_mean + xi_i otherwise.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace ekf_vislam {

/// Which variables the state holds and where their rows are. Order: pose, bias, speed scale, twist
/// rotation, disparity offset, baseline scale, track drift rate, road tilt, gravity (level,
/// accelerometer bias), clone, then the landmarks (3 rows each).
struct StateLayout {
  static constexpr int kPoseRow = 0;
  static constexpr int kPoseDim = 6;
  /// Entries of u = [v; w] whose bias is estimated (one state row each, in this order).
  std::vector<int> bias_components;
  /// 1 when the twist's speed scale is estimated (v_true = (v_m - b_v) + k (v_ref - b_v),
  /// Propagator)
  int speed_scale_dim = 0;
  int rotation_dim = 0;   ///< 3 when the twist rotation R_m is estimated
  int disparity_dim = 0;  ///< 1 when the disparity offset is estimated
  int scale_dim = 0;      ///< 1 when the baseline scale is estimated
  int drift_dim = 0;      ///< 3 when the track drift rate is estimated
  int tilt_dim = 0;       ///< 2 with the road tilt (vehicle/tilt_sigma > 0)
  /// 5 with the accelerometer's states, the world's tilt against gravity (2) then the
  /// accelerometer bias (3): added by FilterState::addGravityRows at the first accelerometer
  /// sample (gravity/enabled, SLAM mode), so that a robot without one carries no idle rows
  int gravity_dim = 0;
  int clone_dim = 0;  ///< 6 when the pose clone has rows (repeated frames, SLAM mode)
  /// A second covariance, the reported one, is carried beside the one the gains use
  /// (noise/report_track_correlation): same propagation, augmentation and marginalization; its
  /// updates use the gains of the first with a larger observation noise (Joseph form).
  bool reported_covariance = false;

  int biasDim() const { return static_cast<int>(bias_components.size()); }
  int biasRow() const { return kPoseDim; }
  int speedScaleRow() const { return biasRow() + biasDim(); }
  int rotationRow() const { return speedScaleRow() + speed_scale_dim; }
  int calibrationRow() const { return rotationRow() + rotation_dim; }
  int calibrationDim() const { return disparity_dim + scale_dim; }
  int disparityRow() const { return calibrationRow(); }
  int scaleRow() const { return calibrationRow() + disparity_dim; }
  int driftRow() const { return calibrationRow() + calibrationDim(); }
  int tiltRow() const { return driftRow() + drift_dim; }
  int levelRow() const { return tiltRow() + tilt_dim; }
  int accelBiasRow() const { return levelRow() + 2; }
  /// States between the pose and the clone: bias, speed scale, twist rotation, calibration, track
  /// drift, road tilt, gravity.
  int auxDim() const {
    return biasDim() + speed_scale_dim + rotation_dim + calibrationDim() + drift_dim + tilt_dim +
           gravity_dim;
  }
  int cloneRow() const { return kPoseDim + auxDim(); }
  /// Rows before the first landmark.
  int headDim() const { return cloneRow() + clone_dim; }
  int landmarkRow(size_t index) const { return headDim() + 3 * static_cast<int>(index); }
};

/// Initial standard deviations of the variables (prior/, bias/, extrinsic/, intrinsic/ options).
struct StatePrior {
  double position_sigma = 0.0;  ///< m, isotropic in world axes
  double rotation_sigma = 0.0;  ///< rad
  double velocity_bias_sigma = 0.0;
  double gyro_bias_sigma = 0.0;
  double speed_scale_sigma = 0.0;  ///< relative
  /// The speed scale is not estimated, only counted: with a reported covariance its prior goes
  /// there alone (the gains' covariance, and so the estimate, never see it).
  bool speed_scale_reported_only = false;
  double twist_rotation_sigma = 0.0;
  /// The disparity offset is only counted: its prior goes to the reported covariance alone.
  bool disparity_offset_reported_only = false;
  double disparity_offset_sigma = 0.0;
  double baseline_scale_sigma = 0.0;
  double track_drift_rate_sigma = 0.0;  ///< rad/s, each IMU axis
  double road_tilt_sigma = 0.0;         ///< rad, each world axis
  double level_sigma = 0.0;             ///< rad, each world axis (the world's tilt)
  double accel_bias_sigma = 0.0;        ///< m/s^2, each IMU axis
};

class FilterState {
 public:
  explicit FilterState(StateLayout layout);

  const StateLayout& layout() const { return layout_; }
  /// Active dimension: head plus 3 per landmark.
  int dim() const { return dim_; }
  size_t landmarkCount() const { return static_cast<size_t>(dim_ - layout_.headDim()) / 3; }

  /// Covariances carried: 1, or 2 with layout().reported_covariance (0: the gains' covariance,
  /// 1: the reported one).
  int covarianceCount() const { return layout_.reported_covariance ? 2 : 1; }

  /// The reported covariance's track-noise part M (with layout().reported_covariance), carried
  /// from the start until foldTrackNoise: one more matrix that every linear step maps as it
  /// maps the covariances (propagation, augmentation, marginalization, the updates' Joseph form)
  /// and that takes no noise but the tracks' own in the image updates, at the pixel variance.
  /// While it is carried the reported covariance counts the tracks at the pixel variance too, so
  /// it is A + M (A: the rest). Readable as covariance(kTrackNoise).
  static constexpr int kTrackNoise = 2;
  /// Matrices carried: covarianceCount(), plus the track-noise part until folded.
  int carriedCount() const { return covarianceCount() + (track_noise_carried_ ? 1 : 0); }
  bool carriesTrackNoise() const { return track_noise_carried_; }
  /// Counts the tracks' noise of every update so far at `factor` times the pixel variance:
  /// reported += (factor - 1) M (exact: the reported covariance is affine in that noise), then
  /// drops the part: later updates count at their own factor. Nothing when it is not carried.
  void foldTrackNoise(double factor);
  /// Live covariance block (dim x dim) of the capacity-sized storage: `which` 0 is the one the
  /// gains use, 1 the reported one (when carried). Applies the deferred predictions first.
  Eigen::Block<Eigen::MatrixXd> covariance(int which = 0) {
    applyDeferredPredictions();
    return storage(which).topLeftCorner(dim_, dim_);
  }
  Eigen::Block<const Eigen::MatrixXd> covariance(int which = 0) const {
    applyDeferredPredictions();
    const Eigen::MatrixXd& stored = storage(which);
    return stored.topLeftCorner(dim_, dim_);
  }
  /// The pose block (6 x 6) and the auxiliary block (auxDim x auxDim) of covariance(which), read
  /// without applying the deferred predictions (cheap at twist rate).
  Matrix6d poseCovariance(int which) const;
  Eigen::MatrixXd auxCovariance(int which) const;

  /// Prediction by one twist step, the part that costs O(dim^2) deferred until a covariance is
  /// read. The step maps the covariance to F S F^T + D Q D^T + diag(random_walk) with
  /// F = I + D G A, where A picks the auxiliary rows, D (dim x 6) is the identity on the pose
  /// rows and p_i^ on each landmark's rotation columns (when landmarks_follow_pose; zero rows
  /// elsewhere), G = gain (6 x auxDim), Q = noise (6 x 6, world frame) and random_walk (auxDim)
  /// the auxiliary variances added. Since A D = 0, n steps compose exactly into
  /// F = I + D (sum G) A and sums of small matrices (doc/estimator.md, Prediction).
  void deferPrediction(const Eigen::MatrixXd& gain, const Matrix6d& noise,
                       const Eigen::VectorXd& random_walk, bool landmarks_follow_pose);
  /// Sum of the pose's process noise Q (world frame) of the steps deferred since the last
  /// markUpdate(): what the prediction since the last update added to the pose.
  const Matrix6d& processNoiseSinceUpdate() const { return noise_since_update_; }
  void markUpdate() { noise_since_update_.setZero(); }
  /// More process noise for the steps already taken: D noise D^T added to every covariance (D as
  /// in deferPrediction), the mean unchanged.
  void addPoseProcessNoise(const Matrix6d& noise, bool landmarks_follow_pose);
  /// Scales the road tilt's rows and columns by f and adds `variance` to its diagonal in every
  /// covariance; commutes with the deferred predictions (D and G have no tilt entries), so none
  /// is applied.
  void propagateRoadTiltCovariance(double f, double variance);
  /// Sets the variance of the error of rows [row, row + dim) along the unit `direction` to
  /// `variance` in the reported covariance, everything correlated with those rows in proportion:
  /// the error is e = C S^-1 e_b + r (e_b the rows' error, C their columns, S their block, r
  /// independent of e_b), and e_b takes (variance - u^T S u) along u = direction, so P changes
  /// by that times g g^T, g = C S^-1 u. Nothing when S is not positive definite.
  void setReportedVarianceAlong(int row, int dim, const Eigen::VectorXd& direction,
                                double variance);
  /// Sets the standard deviation of a row the reported covariance alone carries (a consider
  /// row: its gains' row is zero) to `sigma`, as if its prior had been that: the state's error is
  /// e = a + [b; 1] c (c the row's variable, independent of a), so the covariance is
  /// A + var(c) [b; 1] [b; 1]^T, and that part scales by sigma^2 / var(c). Exact while every
  /// operation since the prior was linear in the covariance. Nothing without a positive variance.
  void setConsiderSigma(int row, double sigma) {
    if (sigma > 0.0) setReportedVarianceAlong(row, 1, Eigen::VectorXd::Ones(1), sigma * sigma);
  }
  /// The covariance the outputs report: the reported one when carried, else the gains' one.
  Eigen::Block<const Eigen::MatrixXd> reportedCovariance() const {
    return covariance(covarianceCount() - 1);
  }

  // Means.
  Eigen::Matrix4d imu_T_world = Eigen::Matrix4d::Identity();
  /// Pose at the last repeated frame; its error has rows when layout().clone_dim is 6.
  Eigen::Matrix4d imu_T_world_clone = Eigen::Matrix4d::Identity();
  Eigen::VectorXd bias;            ///< estimated bias components (layout().bias_components)
  double speed_scale_error = 0.0;  ///< k: the true speed is 1 + k times the measured one
  Eigen::Matrix3d imu_R_twist = Eigen::Matrix3d::Identity();  ///< R_m
  double disparity_offset = 0.0;                              ///< px, measured minus true disparity
  double baseline_scale_error = 0.0;  ///< beta: baseline = calibrated baseline x (1 + beta)
  /// Rate (rad/s, IMU axes) at which the feature tracks turn away from their points: an
  /// observation of age a (s since its landmark started) shows the point at exp(a w^) p_imu.
  Eigen::Vector3d track_drift_rate_imu = Eigen::Vector3d::Zero();
  /// Tilt of the road under the vehicle: the world-x and world-y components of the road's
  /// normal (0 on a road as level as the first pose); the vehicle's up axis follows it.
  Eigen::Vector2d road_tilt_world = Eigen::Vector2d::Zero();
  /// Gravity's up axis in world axes: its x and y components (z = sqrt(1 - x^2 - y^2)); 0 when
  /// the first pose is level.
  Eigen::Vector2d gravity_level_world = Eigen::Vector2d::Zero();
  Eigen::Vector3d accel_bias_imu = Eigen::Vector3d::Zero();  ///< m/s^2, measured minus true
  /// When set, applyCorrection moves each landmark in front of this camera in inverse-depth
  /// coordinates of the camera (x/z, y/z, 1/z), in which a stereo observation is linear, instead
  /// of in world coordinates: the same first-order correction, a different retraction.
  std::optional<Eigen::Matrix4d> inverse_depth_cam_T_imu;
  Eigen::Vector3d landmark(size_t index) const {
    return landmark_means_.segment<3>(layout_.landmarkRow(index));
  }
  void setLandmark(size_t index, const Eigen::Vector3d& p_world) {
    applyDeferredPredictions();  // D holds the landmark means
    landmark_means_.segment<3>(layout_.landmarkRow(index)) = p_world;
  }

  /// Means to the origin, no landmark, then setPrior.
  void reset(const StatePrior& prior);
  /// Head covariance from the prior about the current pose (landmark rows must be gone), and the
  /// clone set to the pose.
  void setPrior(const StatePrior& prior);
  /// The bias as a full [v; w] vector (zeros where not estimated).
  Vector6d biasVector() const;
  /// Copies the pose into the clone (mean, and covariance rows and columns when it has rows).
  void clonePose();

  /// Adds one landmark at the end: mean, covariance with the rest of the state (3 x dim) and its
  /// own (3 x 3), the same in every covariance carried.
  void appendLandmark(const Eigen::Vector3d& p_world, const Eigen::MatrixXd& cross_covariance,
                      const Eigen::Matrix3d& own_covariance);
  /// The same with one cross and own covariance per covariance carried (covarianceCount()).
  void appendLandmark(const Eigen::Vector3d& p_world,
                      const std::vector<Eigen::MatrixXd>& cross_covariances,
                      const std::vector<Eigen::Matrix3d>& own_covariances);
  /// Inserts the gravity rows (layout().gravity_dim 0 -> 5, before the clone): level and
  /// accelerometer bias at zero with these prior standard deviations, uncorrelated with the rest,
  /// in every covariance. Applies the deferred predictions first.
  void addGravityRows(double level_sigma, double accel_bias_sigma);
  /// Keeps only these rows (ascending, the head included), in place; capacity shrinks after a
  /// burst.
  void keepRows(const std::vector<int>& rows);
  /// Applies an EKF correction dx (dim) to every mean; the pose (and the landmarks' rotation
  /// with it) only when correct_pose.
  void applyCorrection(const Eigen::VectorXd& dx, bool correct_pose);

 private:
  /// The deferred twist steps, composed (deferPrediction).
  struct DeferredPredictions {
    int steps = 0;
    bool landmarks_follow_pose = false;
    Eigen::MatrixXd gain_sum;               ///< 6 x aux: sum of G
    Matrix6d noise_sum = Matrix6d::Zero();  ///< sum of Q
    Eigen::VectorXd random_walk_sum;        ///< aux: sum of the random-walk variances
    Eigen::MatrixXd walk_cross;  ///< 6 x aux: sum_k H_k diag(r_k), H_k = G of later steps
    Matrix6d walk_outer = Matrix6d::Zero();  ///< sum_k H_k diag(r_k) H_k^T
  };
  void applyDeferredPredictions() const;
  /// D (dim x 6) of the deferred steps.
  Eigen::MatrixXd deferredNoiseMap() const;

  void ensureCapacity(int dim);
  Eigen::MatrixXd& storage(int which) const {
    return which == 0 ? sigma_ : which == 1 ? sigma_reported_ : track_noise_;
  }

  StateLayout layout_;
  int dim_ = 0;
  Eigen::VectorXd landmark_means_;  ///< landmark means at their state rows (capacity sized)
  // The covariances, with the deferred predictions not yet in them (mutable: reading a
  // covariance applies them).
  mutable Eigen::MatrixXd sigma_;           ///< capacity >= dim_; the top-left dim_ block is live
  mutable Eigen::MatrixXd sigma_reported_;  ///< the same size, when layout_.reported_covariance
  mutable Eigen::MatrixXd track_noise_;     ///< the track-noise part M, while carried
  bool track_noise_carried_ = false;
  mutable DeferredPredictions deferred_;
  Matrix6d noise_since_update_ = Matrix6d::Zero();
};

}  // namespace ekf_vislam
