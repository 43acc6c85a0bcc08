#include "ekf_vislam/core/vislam_estimator.h"

#include "ekf_vislam/core/chi_square.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/track_jump_detector.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_set>

namespace ekf_vislam {

struct VislamEstimator::Candidate {
  StereoObservation feature;
  size_t block = 0;  ///< state block (update candidates)
  /// Restart of a landmark: overwrite this map entry instead of adding one.
  size_t reuse_map_index = std::numeric_limits<size_t>::max();
  Eigen::VectorXd residual;
  Eigen::MatrixXd H_pose;      ///< rows x 6
  Eigen::MatrixXd H_landmark;  ///< rows x 3
  Eigen::MatrixXd H_calibration;  ///< rows x calibrationDim()
  Eigen::MatrixXd H_clone;     ///< rows x 6, when via_clone in SLAM mode
  /// The track ran through the last repeated frame: this observation shows its landmark from
  /// the clone (the pose at that frame), not from the current pose.
  bool via_clone = false;
  double mahalanobis2 = 0.0;   ///< of the residual against its own innovation covariance
  bool predicted = false;      ///< false: the landmark is not in front of the camera
  bool jumped = false;         ///< the track-jump test flagged it
};

namespace {

bool allFinite(const StereoObservation& f) {
  return std::isfinite(f.u_left) && std::isfinite(f.v_left) && std::isfinite(f.u_right) &&
         std::isfinite(f.v_right);
}

// Rows of the stereo observation used by the update: [uL, (vL + vR) / 2, uR] or all four.
Eigen::MatrixXd observationSelector(bool merge_rows) {
  if (!merge_rows) return Eigen::Matrix4d::Identity();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(3, 4);
  M(0, 0) = 1.0;
  M(1, 1) = 0.5;
  M(1, 3) = 0.5;
  M(2, 2) = 1.0;
  return M;
}

}  // namespace

VislamEstimator::VislamEstimator(const VislamOptions& options) : options_(options) {
  rows_per_observation_ = options_.merge_stereo_rows ? 3 : 4;
  observation_selector_ = observationSelector(options_.merge_stereo_rows);
  gate_threshold_ = chiSquareQuantile(options_.gating_probability, rows_per_observation_);
  restart_threshold_ = chiSquareQuantile(0.9999, rows_per_observation_);
  if (options_.estimate_velocity_bias) bias_components_.insert(bias_components_.end(), {0, 1, 2});
  if (options_.estimate_gyro_bias) bias_components_.insert(bias_components_.end(), {3, 4, 5});
  bias_dim_ = static_cast<int>(bias_components_.size());
  rotation_dim_ = options_.estimate_twist_rotation ? 3 : 0;
  clone_dim_ = options_.repeated_frames == RepeatedFramePolicy::kShift &&
                       options_.mode == EstimatorMode::kSlam
                   ? kPoseDim
                   : 0;
  disparity_dim_ = options_.estimate_disparity_offset ? 1 : 0;
  scale_dim_ = options_.estimate_baseline_scale ? 1 : 0;
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
  applyBaselineScale();
  return true;
}

void VislamEstimator::applyBaselineScale() {
  StereoCalibration scaled = nominal_calibration_;
  scaled.baseline *= 1.0 + baseline_scale_error_;
  camera_ = StereoCamera(scaled);
}

void VislamEstimator::setPriorCovariance() {
  sigma_.topLeftCorner(dim_, dim_).setZero();
  const double p2 = options_.prior_position_sigma * options_.prior_position_sigma;
  const double r2 = options_.prior_rotation_sigma * options_.prior_rotation_sigma;
  // The prior is isotropic in (delta p, delta theta) about the current position; the internal
  // world-frame error has rho = delta p - phi x p, i.e. Sigma = M^-1 diag M^-T, M^-1 = [[I, p^],
  // [0, I]] (the identity at the origin).
  Matrix6d M_inv = Matrix6d::Identity();
  M_inv.topRightCorner<3, 3>() = se3::hat(Eigen::Vector3d(worldTImu().translation()));
  Vector6d prior;
  prior << p2, p2, p2, r2, r2, r2;
  sigma_.topLeftCorner<6, 6>() = M_inv * prior.asDiagonal() * M_inv.transpose();
  for (int i = 0; i < bias_dim_; ++i) {
    const double s = bias_components_[i] < 3 ? options_.velocity_bias_prior_sigma
                                             : options_.gyro_bias_prior_sigma;
    sigma_(kPoseDim + i, kPoseDim + i) = s * s;
  }
  const double rot2 = options_.twist_rotation_prior_sigma * options_.twist_rotation_prior_sigma;
  for (int i = 0; i < rotation_dim_; ++i) {
    sigma_(kPoseDim + bias_dim_ + i, kPoseDim + bias_dim_ + i) = rot2;
  }
  if (disparity_dim_ > 0) {
    sigma_(disparityRow(), disparityRow()) =
        options_.disparity_offset_prior_sigma * options_.disparity_offset_prior_sigma;
  }
  if (scale_dim_ > 0) {
    sigma_(scaleRow(), scaleRow()) =
        options_.baseline_scale_prior_sigma * options_.baseline_scale_prior_sigma;
  }
  crossing_ids_.clear();
  clonePose();
}

void VislamEstimator::clonePose() {
  imu_T_world_clone_ = imu_T_world_;
  if (clone_dim_ == 0) return;
  // The clone's error equals the pose error now: rows, then columns (which sets the clone block
  // to the pose block).
  auto S = sigma_.topLeftCorner(dim_, dim_);
  const int c = cloneRow();
  S.middleRows(c, kPoseDim) = S.topRows(kPoseDim);
  S.middleCols(c, kPoseDim) = S.leftCols(kPoseDim);
}

void VislamEstimator::initializeState() {
  initialized_ = false;
  time_ = 0.0;
  last_twist_stamp_ = 0.0;
  in_twist_gap_ = false;
  has_frame_ = false;
  repeated_frames_.reset();
  jump_test_paused_ = false;
  last_frame_stamp_ = 0.0;
  held_twist_ = TwistData();
  imu_T_world_.setIdentity();
  bias_ = Eigen::VectorXd::Zero(bias_dim_);
  imu_R_twist_.setIdentity();
  disparity_offset_ = 0.0;
  baseline_scale_error_ = 0.0;
  if (has_calibration_) applyBaselineScale();
  dim_ = headDim();
  const int capacity = std::max(64, dim_);
  sigma_ = Eigen::MatrixXd::Zero(capacity, capacity);
  p_world_ = Eigen::VectorXd::Zero(capacity);
  setPriorCovariance();
  blocks_.clear();
  tracking_.clear();
  map_.clear();
  consecutive_rejected_frames_ = 0;
}

void VislamEstimator::reset() { initializeState(); }

void VislamEstimator::ensureCapacity(int dim) {
  const int capacity = static_cast<int>(sigma_.rows());
  if (dim <= capacity) return;
  const int new_capacity = std::max(dim, 2 * capacity);
  Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(new_capacity, new_capacity);
  grown.topLeftCorner(dim_, dim_) = sigma_.topLeftCorner(dim_, dim_);
  sigma_.swap(grown);
  Eigen::VectorXd grown_mean = Eigen::VectorXd::Zero(new_capacity);
  grown_mean.head(dim_) = p_world_.head(dim_);
  p_world_.swap(grown_mean);
}

Vector6d VislamEstimator::trueTwist(const TwistData& twist) const {
  const Vector6d b = biasVector();
  const Eigen::Vector3d v_twist = twist.v_imu - b.head<3>();
  const Eigen::Vector3d w_twist = twist.w_imu - b.tail<3>();
  Vector6d u;
  u.head<3>() = velocityPriorGain(twist).head<3>().cwiseProduct(imu_R_twist_ * v_twist);
  u.tail<3>() = imu_R_twist_ * w_twist;
  return u;
}

Vector6d VislamEstimator::velocityPriorGain(const TwistData& twist) const {
  // A measured component (IMU frame) with per-sample variance r fused with a zero-mean prior of
  // variance s^2: mean g * measured, variance g * r, with g = s^2 / (s^2 + r). r is the
  // message's own variance when it carries a covariance (noise/use_message_covariance), else
  // sigma_v^2 / dt (isotropic: rotating by R_m keeps it).
  Vector6d gain = Vector6d::Ones();
  const bool own = usesMessageCovariance(twist);
  const Matrix6d own_density = own ? messageTwistDensity(twist) : Matrix6d::Zero();
  const double dt = std::max(1e-3, last_twist_dt_);
  const double r_configured = options_.linear_velocity_noise * options_.linear_velocity_noise / dt;
  const double sigmas[2] = {options_.lateral_velocity_sigma, options_.vertical_velocity_sigma};
  for (int axis = 1; axis <= 2; ++axis) {
    const double r = own ? own_density(axis, axis) / dt : r_configured;
    const double s2 = sigmas[axis - 1] * sigmas[axis - 1];
    if (s2 > 0.0 && r > 0.0) gain(axis) = s2 / (s2 + r);
  }
  return gain;
}

bool VislamEstimator::usesMessageCovariance(const TwistData& twist) const {
  return options_.use_message_covariance && twist.hasCovariance();
}

Matrix6d VislamEstimator::messageTwistDensity(const TwistData& twist) const {
  // Per-sample covariance of the message, rotated into the IMU frame, times the sample period.
  Matrix6d R = Matrix6d::Zero();
  R.topLeftCorner<3, 3>() = imu_R_twist_;
  R.bottomRightCorner<3, 3>() = imu_R_twist_;
  return std::max(1e-3, last_twist_dt_) * R * twist.covariance * R.transpose();
}

Vector6d VislamEstimator::biasVector() const {
  Vector6d b = Vector6d::Zero();
  for (int i = 0; i < bias_dim_; ++i) b(bias_components_[i]) = bias_(i);
  return b;
}

Matrix6d VislamEstimator::twistNoiseDensity(const TwistData& twist) const {
  // Body-frame noise density of u (W = density * tau), per axis reduced by the vehicle prior.
  const Vector6d gain = velocityPriorGain(twist);
  if (usesMessageCovariance(twist)) {
    const Vector6d root = gain.cwiseSqrt();
    return root.asDiagonal() * messageTwistDensity(twist) * root.asDiagonal();
  }
  const double qv = options_.linear_velocity_noise * options_.linear_velocity_noise;
  const double qw = options_.angular_velocity_noise * options_.angular_velocity_noise;
  Vector6d q = gain;
  q.head<3>() *= qv;
  q.tail<3>() *= qw;
  return q.asDiagonal();
}

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
  if (!std::isfinite(twist.stamp) || !twist.v_imu.allFinite() || !twist.w_imu.allFinite()) {
    return reject(Counter::kTwistNonFinite, "twist with NaN/Inf rejected");
  }
  if (twist.v_imu.norm() > options_.max_linear_speed ||
      twist.w_imu.norm() > options_.max_angular_speed) {
    std::ostringstream why;
    why << "implausible twist rejected (|v| = " << twist.v_imu.norm()
        << " m/s, |w| = " << twist.w_imu.norm() << " rad/s; limits/max_linear_speed = "
        << options_.max_linear_speed << ", limits/max_angular_speed = "
        << options_.max_angular_speed << ")";
    return reject(Counter::kTwistImplausible, why.str());
  }
  if (!initialized_) {
    initialized_ = true;
    time_ = last_twist_stamp_ = twist.stamp;
    held_twist_ = twist;
    stats_.increment(Counter::kTwistUsed);
    return result;
  }
  if (twist.stamp <= last_twist_stamp_) {
    std::ostringstream why;
    why << "twist stamp " << std::fixed << twist.stamp << " not after the previous twist ("
        << last_twist_stamp_ << "): " << (twist.stamp == last_twist_stamp_ ? "duplicate" : "time went backwards");
    return reject(Counter::kTwistNotIncreasing, why.str());
  }
  const double previous_twist_stamp = last_twist_stamp_;
  last_twist_dt_ = twist.stamp - last_twist_stamp_;
  last_twist_stamp_ = twist.stamp;
  if (twist.stamp < time_) {
    // A feature frame after this stamp was already processed: keep it for the next interval.
    held_twist_ = twist;
    stats_.increment(Counter::kTwistLate);
    result.message = "twist older than the filter time: held without prediction";
    return result;
  }
  advanceTo(twist.stamp, twist, previous_twist_stamp, &result);
  in_twist_gap_ = false;
  held_twist_ = twist;
  stats_.increment(Counter::kTwistUsed);
  return result;
}

void VislamEstimator::advanceTo(double stamp, const TwistData& twist, double twist_stamp,
                                FeedResult* result) {
  const double dt = stamp - time_;
  if (dt <= 0.0) return;
  double noise_scale = 1.0;
  const double since_twist = stamp - twist_stamp;
  if (since_twist > options_.max_twist_gap) {
    // No twist for too long (whether frames kept coming or not): once per gap, apply the policy.
    noise_scale = options_.gap_noise_scale;
    jump_test_paused_ = true;
    if (!in_twist_gap_) {
      in_twist_gap_ = true;
      stats_.increment(Counter::kTwistGap);
      std::ostringstream why;
      why << "no twist for " << since_twist << " s (limits/max_twist_gap = "
          << options_.max_twist_gap << " s): ";
      if (options_.gap_policy == GapPolicy::kReset) {
        why << "filter reset (map kept)";
        removeBlocks(std::vector<bool>(blocks_.size(), true));
        imu_T_world_.setIdentity();
        bias_.setZero();
        setPriorCovariance();
        time_ = stamp;
        result->message = why.str();
        return;
      }
      why << "predicting across with process noise x " << options_.gap_noise_scale;
      result->message = why.str();
    }
  }
  predict(dt, twist, noise_scale);
  time_ = stamp;
}

void VislamEstimator::predict(double dt, const TwistData& twist, double noise_scale) {
  const Vector6d u = trueTwist(twist);
  const Vector6d xi = -dt * u;
  const Eigen::Matrix4d motion = se3::exp(xi);
  imu_T_world_ = motion * imu_T_world_;
  se3::normalizeRotation(&imu_T_world_);

  // World-frame error: T' = exp(eps^) T_mean exp(dt (u - b)^), so eps' = eps + d with
  // d = -dt Ad(T') J_l(xi) db + Ad(T') dt n (n: twist noise). A change d of the pose error moves
  // the invariant landmark errors too: xi_i' = xi_i + p_i^ d_phi (the landmark is static,
  // exp(phi^) p_mean is not). D maps d into the state: identity on the pose, [0, p_i^] on each
  // landmark (SLAM mode; in mapping mode the landmarks do not depend on the pose).
  const Matrix6d Ad = se3::adjoint(se3::inverse(imu_T_world_));  // Ad(world_T_imu after the step)
  auto S = sigma_.topLeftCorner(dim_, dim_);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(dim_, kPoseDim);
  D.topLeftCorner<6, 6>().setIdentity();
  if (options_.mode == EstimatorMode::kSlam) {
    for (size_t k = 0; k < blocks_.size(); ++k) {
      const int row = landmarkRow(k);
      D.block<3, 3>(row, 3) = se3::hat(Eigen::Vector3d(p_world_.segment<3>(row)));
    }
  }
  const int aux = auxDim();
  if (aux > 0) {
    // F = I + E on the auxiliary columns, E = D G (dim x aux), G = dt Ad J_l(xi) du/daux with
    // u = [Gv R_m (v - b_v); R_m (w - b_w)] (Gv: vehicle prior gains): du/db = -[Gv R_m; R_m]
    // (bias components) and du/dtheta = -[Gv (R_m (v - b_v))^; (R_m (w - b_w))^].
    Eigen::MatrixXd du_daux = Eigen::MatrixXd::Zero(kPoseDim, aux);
    const Eigen::Matrix3d Gv = velocityPriorGain(twist).head<3>().asDiagonal();
    for (int i = 0; i < bias_dim_; ++i) {
      const int c = bias_components_[i];
      if (c < 3) {
        du_daux.block<3, 1>(0, i) = -Gv * imu_R_twist_.col(c);
      } else {
        du_daux.block<3, 1>(3, i) = -imu_R_twist_.col(c - 3);
      }
    }
    if (rotation_dim_ > 0) {
      const Eigen::Vector3d v_imu = imu_R_twist_ * (twist.v_imu - biasVector().head<3>());
      du_daux.block<3, 3>(0, bias_dim_) = -Gv * se3::hat(v_imu);
      du_daux.block<3, 3>(3, bias_dim_) = -se3::hat(Eigen::Vector3d(u.tail<3>()));
    }
    const Eigen::MatrixXd G = dt * Ad * se3::leftJacobian(xi) * du_daux;
    const Eigen::MatrixXd E = D * G;
    const Eigen::MatrixXd E_sigma = E * S.middleRows(kPoseDim, aux);  // dim x dim
    const Eigen::MatrixXd sigma_aa = S.block(kPoseDim, kPoseDim, aux, aux);
    S += E_sigma + E_sigma.transpose() + E * sigma_aa * E.transpose();
  }
  const Matrix6d Q_world = (noise_scale * dt) * Ad * twistNoiseDensity(twist) * Ad.transpose();
  S.noalias() += D * Q_world * D.transpose();
  for (int i = 0; i < bias_dim_; ++i) {
    const double rw = bias_components_[i] < 3 ? options_.velocity_bias_random_walk
                                              : options_.gyro_bias_random_walk;
    S(kPoseDim + i, kPoseDim + i) += dt * rw * rw;
  }
  const double rot_rw = options_.twist_rotation_random_walk;
  for (int i = 0; i < rotation_dim_; ++i) {
    S(kPoseDim + bias_dim_ + i, kPoseDim + bias_dim_ + i) += dt * rot_rw * rot_rw;
  }
  if (disparity_dim_ > 0) {
    const double rw = options_.disparity_offset_random_walk;
    S(disparityRow(), disparityRow()) += dt * rw * rw;
  }
  if (scale_dim_ > 0) {
    const double rw = options_.baseline_scale_random_walk;
    S(scaleRow(), scaleRow()) += dt * rw * rw;
  }
}

// ---------------------------------------------------------------------------------------------
// Feature frames
// ---------------------------------------------------------------------------------------------

FeedResult VislamEstimator::feedFeatures(const FeatureFrame& frame) {
  FeedResult result;
  auto reject = [&](Counter counter, const std::string& why) {
    stats_.increment(counter);
    result.accepted = false;
    result.message = why;
    result.observations_rejected = static_cast<int>(frame.features.size());
    return result;
  };
  if (!std::isfinite(frame.stamp)) {
    return reject(Counter::kFrameNonFiniteStamp, "feature frame with NaN/Inf stamp rejected");
  }
  if (!initialized_) {
    return reject(Counter::kFrameBeforeTwist, "feature frame before the first twist rejected");
  }
  if (!has_calibration_) {
    return reject(Counter::kFrameNoCalibration,
                  "feature frame rejected: no valid stereo calibration yet");
  }
  if (frame.stamp < time_ || (has_frame_ && frame.stamp <= last_frame_stamp_)) {
    std::ostringstream why;
    why << "feature frame " << std::fixed << frame.stamp
        << (has_frame_ && frame.stamp == last_frame_stamp_ ? " repeats the previous frame"
                                                           : " is older than the filter time")
        << ": rejected";
    return reject(Counter::kFrameStale, why.str());
  }
  advanceTo(frame.stamp, held_twist_, last_twist_stamp_, &result);
  has_frame_ = true;
  last_frame_stamp_ = frame.stamp;
  stats_.increment(Counter::kFrameUsed);
  if (frame.features.empty()) stats_.increment(Counter::kFrameEmpty);
  std::vector<size_t> new_tracks;
  if (repeated_frames_.isRepeat(frame, &new_tracks)) {
    stats_.increment(Counter::kFrameRepeated);
    if (options_.repeated_frames != RepeatedFramePolicy::kUse) {
      // Predicted to its stamp (the trajectory has a pose there); its shared tracks are copies.
      result.message =
          "feature frame repeats the previous one (every shared track identical): skipped";
      if (options_.repeated_frames == RepeatedFramePolicy::kShift &&
          options_.mode != EstimatorMode::kDeadReckoning) {
        holdRepeatedFrame(frame, new_tracks, &result);
      }
      return result;
    }
  }
  if (options_.mode == EstimatorMode::kDeadReckoning) {
    stats_.increment(Counter::kObsIgnoredDeadReckoning, frame.features.size());
    return result;
  }
  processFrame(frame, &result);
  return result;
}

void VislamEstimator::holdRepeatedFrame(const FeatureFrame& frame,
                                        const std::vector<size_t>& new_tracks,
                                        FeedResult* result) {
  // Measured on the course files (doc/estimator.md, "Repeated frames"): from the next frame on, each track
  // through a repeated frame reports its landmark carried along by that frame's motion. With
  // equal motion over the repeated frame and the next one, its next observation is the landmark
  // seen from the pose at the repeated frame (the clone), which bridges the frame; then the
  // landmark is moved by the clone-to-now motion (shiftCrossingTracks). The tracks that start in
  // the repeated frame are fresh measurements at its stamp.
  if (!crossing_ids_.empty()) shiftCrossingTracks(result);  // two repeated frames in a row
  for (const StereoObservation& f : frame.features) {
    auto it = tracking_.find(f.id);
    if (it == tracking_.end()) continue;
    crossing_ids_.insert(f.id);
    blocks_[it->second].has_flow_reference = false;  // its next observation is not comparable
  }
  clonePose();
  for (size_t i : new_tracks) {
    const StereoObservation& f = frame.features[i];
    if (tracking_.count(f.id) || !screenObservation(f, result)) continue;
    Candidate c;
    c.feature = f;
    initializeLandmark(c, frame.stamp, result);
  }
  syncBlocksToMap();
}

void VislamEstimator::shiftCrossingTracks(FeedResult* result) {
  // p' = Delta p with Delta = world_T_imu * imu_T_world(clone). With the invariant errors
  // (p = exp(phi^) p_mean + xi for the current pose, clone error [rho_c; phi_c]) the new error is
  // xi' = R_D xi + rho - R_D p^ phi - R_D rho_c + R_D p^ phi_c (first order; R_D of Delta), and
  // in mapping mode (no pose errors) xi' = R_D xi. Sigma <- J Sigma J^T, J the identity except
  // the moved landmarks' rows: rows first (each new row uses its own old row and the pose and
  // clone rows, which do not change), then columns the same way.
  const Eigen::Matrix4d world_T_imu = se3::inverse(imu_T_world_);
  const Eigen::Matrix4d delta = world_T_imu * imu_T_world_clone_;
  const Eigen::Matrix3d R = delta.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = delta.topRightCorner<3, 1>();
  auto S = sigma_.topLeftCorner(dim_, dim_);
  const bool slam = clone_dim_ > 0;
  const int c = cloneRow();
  std::vector<std::pair<int, Eigen::Matrix3d>> moved;  // landmark row, R_D p^ (old mean)
  for (uint32_t id : crossing_ids_) {
    auto it = tracking_.find(id);
    if (it == tracking_.end()) continue;  // ended, or restarted from its new observation
    const int row = landmarkRow(it->second);
    const Eigen::Vector3d p = p_world_.segment<3>(row);
    const Eigen::Matrix3d Rp = R * se3::hat(p);
    Eigen::MatrixXd rows = R * S.middleRows(row, 3);
    if (slam) {
      rows += S.topRows(3) - Rp * S.middleRows(3, 3) - R * S.middleRows(c, 3) +
              Rp * S.middleRows(c + 3, 3);
    }
    S.middleRows(row, 3) = rows;
    p_world_.segment<3>(row) = R * p + t;
    moved.emplace_back(row, Rp);
    blocks_[it->second].has_flow_reference = false;
    stats_.increment(Counter::kLandmarkShifted);
    ++result->landmarks_shifted;
  }
  for (const auto& [row, Rp] : moved) {
    Eigen::MatrixXd cols = S.middleCols(row, 3) * R.transpose();
    if (slam) {
      cols += S.leftCols(3) - S.middleCols(3, 3) * Rp.transpose() -
              S.middleCols(c, 3) * R.transpose() + S.middleCols(c + 3, 3) * Rp.transpose();
    }
    S.middleCols(row, 3) = cols;
  }
  const Eigen::Vector3d p_camera_world =
      world_T_imu.topLeftCorner<3, 3>() * camera_.imuTCam().topRightCorner<3, 1>() +
      world_T_imu.topRightCorner<3, 1>();
  const double relative_var =
      options_.repeated_frame_depth_sigma * options_.repeated_frame_depth_sigma;
  for (const auto& moved_row : moved) {
    const int row = moved_row.first;
    S.middleRows(row, 3) = S.middleCols(row, 3).transpose();
    const Eigen::Vector3d ray = p_world_.segment<3>(row) - p_camera_world;
    S.block<3, 3>(row, row) += relative_var * ray * ray.transpose();
  }
  crossing_ids_.clear();
}

bool VislamEstimator::screenObservation(const StereoObservation& f, FeedResult* result) {
  Counter reason;
  if (!allFinite(f)) {
    reason = Counter::kObsNonFinite;
  } else if (!camera_.inImage(f.u_left, f.v_left) || !camera_.inImage(f.u_right, f.v_right)) {
    reason = Counter::kObsOutsideImage;
  } else if (std::fabs(f.v_left - f.v_right) > options_.max_row_difference_px) {
    reason = Counter::kObsRowMismatch;
  } else if (f.u_left - f.u_right < options_.min_disparity_px) {
    reason = Counter::kObsDisparity;
  } else {
    return true;
  }
  stats_.increment(reason);
  ++result->observations_rejected;
  return false;
}

void VislamEstimator::processFrame(const FeatureFrame& frame, FeedResult* result) {
  size_t count = frame.features.size();
  if (options_.max_features_per_frame > 0 &&
      count > static_cast<size_t>(options_.max_features_per_frame)) {
    stats_.increment(Counter::kFrameCapped);
    std::ostringstream why;
    why << "frame with " << count << " features capped to limits/max_features_per_frame = "
        << options_.max_features_per_frame;
    result->message = why.str();
    result->observations_rejected += static_cast<int>(count) - options_.max_features_per_frame;
    count = options_.max_features_per_frame;
  }

  // 1. Screen every feature; collect the ids present (even rejected ones keep their track alive).
  std::unordered_set<uint32_t> present;
  present.reserve(2 * count);
  std::vector<Candidate> updates, initializations;
  updates.reserve(count);
  auto rejectObservation = [&](Counter counter) {
    stats_.increment(counter);
    ++result->observations_rejected;
  };
  for (size_t i = 0; i < count; ++i) {
    const StereoObservation& f = frame.features[i];
    if (!present.insert(f.id).second) {
      rejectObservation(Counter::kObsDuplicateId);
      continue;
    }
    if (auto seen = tracking_.find(f.id); seen != tracking_.end()) ++blocks_[seen->second].frames;
    if (!screenObservation(f, result)) continue;
    Candidate c;
    c.feature = f;
    auto it = tracking_.find(f.id);
    if (it != tracking_.end()) {
      c.block = it->second;
      c.via_clone = crossing_ids_.count(f.id) > 0;
      updates.push_back(std::move(c));
    } else {
      initializations.push_back(std::move(c));
    }
  }

  // 2. Tracks absent for more than landmarks/max_track_gap non-empty frames ended: they leave the
  // state (before the update: a smaller state is cheaper). An empty message ends no track.
  std::vector<bool> ended(blocks_.size(), false);
  bool any_ended = false;
  for (const auto& [id, block] : tracking_) {
    StateBlock& b = blocks_[block];
    if (present.count(id)) {
      b.frames_absent = 0;
    } else if (!frame.features.empty()) {
      b.has_flow_reference = false;  // its next observation is not one frame after the last
      if (++b.frames_absent > options_.max_track_gap) {
        ended[block] = true;
        any_ended = true;
      }
    }
  }
  if (any_ended) {
    if (options_.keep_all_landmarks_in_state) {
      for (size_t k = 0; k < blocks_.size(); ++k) {
        if (ended[k]) {
          tracking_.erase(map_[blocks_[k].map_index].id);
          blocks_[k].tracking = false;
        }
      }
    } else {
      std::vector<size_t> update_map_index;
      for (const Candidate& c : updates) update_map_index.push_back(blocks_[c.block].map_index);
      const size_t before = blocks_.size();
      removeBlocks(ended);
      result->landmarks_marginalized += static_cast<int>(before - blocks_.size());
      for (size_t i = 0; i < updates.size(); ++i) {
        updates[i].block = tracking_.at(map_[update_map_index[i]].id);
      }
    }
  }

  // 3. Joint update with the re-observed landmarks; 4. new landmarks from the corrected pose.
  std::vector<Candidate> reinitialize;
  const int candidates = static_cast<int>(updates.size());
  // Observations that disagree with the filter: gated, or restarted by the jump test.
  auto disagreeing = [this]() {
    return stats_.get(Counter::kObsGated) + stats_.get(Counter::kLandmarkJump);
  };
  const uint64_t gated_before = disagreeing();
  if (!updates.empty()) update(&updates, &reinitialize, result);
  const int gated = static_cast<int>(disagreeing() - gated_before);
  // Tracks through the last repeated frame have been seen from the clone: from now on they
  // report their landmark moved by the clone-to-now motion.
  if (!crossing_ids_.empty()) shiftCrossingTracks(result);
  for (const Candidate& c : reinitialize) initializeLandmark(c, frame.stamp, result);
  for (const Candidate& c : initializations) initializeLandmark(c, frame.stamp, result);
  syncBlocksToMap();
  checkHealth(candidates, gated, result);
}

void VislamEstimator::update(std::vector<Candidate>* candidates,
                             std::vector<Candidate>* reinitialize, FeedResult* result) {
  const int r = rows_per_observation_;
  const Eigen::MatrixXd& M = observation_selector_;
  const double pixel_var = options_.pixel_sigma * options_.pixel_sigma;
  const bool correct_pose = options_.mode == EstimatorMode::kSlam;
  auto S = sigma_.topLeftCorner(dim_, dim_);
  const int nc = calibrationDim();
  const int calibration_row = calibrationRow();
  const int clone_row = cloneRow();

  // Predict each observation and its Mahalanobis distance against its own innovation covariance.
  std::vector<Candidate*> accepted;
  std::vector<size_t> remove_for_reinit, remove_for_split, remove_for_jump;
  accepted.reserve(candidates->size());
  for (Candidate& c : *candidates) {
    const int row = landmarkRow(c.block);
    const Eigen::Vector3d p_world = p_world_.segment<3>(row);
    Eigen::Vector4d z_pred;
    Matrix43d H_landmark;
    const Eigen::Matrix4d& imu_T_world = c.via_clone ? imu_T_world_clone_ : imu_T_world_;
    if (!camera_.project(imu_T_world, p_world, &z_pred, nullptr, &H_landmark,
                         options_.min_depth * 0.5)) {
      stats_.increment(Counter::kObsBehindCamera);
      ++result->observations_rejected;
      blocks_[c.block].has_flow_reference = false;
      continue;
    }
    c.predicted = true;
    const Eigen::Vector4d z(c.feature.u_left, c.feature.v_left, c.feature.u_right,
                            c.feature.v_right);
    // d z / d calibration: the uR row only. Offset: measured uR = true uR - offset. Baseline
    // scale: uR = fx (x - b0 (1 + beta)) / z + cx, d uR / d beta = -fx b0 / z.
    Eigen::Matrix<double, 4, 2> H_calibration = Eigen::Matrix<double, 4, 2>::Zero();
    if (disparity_dim_ > 0) H_calibration(2, 0) = -1.0;
    if (scale_dim_ > 0) {
      H_calibration(2, disparity_dim_) = -(z_pred(0) - z_pred(2)) / (1.0 + baseline_scale_error_);
    }
    c.H_calibration = M * H_calibration.leftCols(nc);
    z_pred(2) -= disparity_offset_;
    c.residual = M * (z - z_pred);
    // Invariant error: p_imu = R^T (p_mean + xi - rho - p) to first order, so the observation
    // depends on rho through -H_landmark and not at all on phi.
    c.H_landmark = M * H_landmark;
    c.H_pose = Eigen::MatrixXd::Zero(r, kPoseDim);
    const bool clone_columns = c.via_clone && clone_dim_ > 0;
    if (clone_columns) {
      // Seen from the clone (error [rho_c; phi_c]): p_imu = R_c^T (p_mean + xi - rho_c +
      // p^ (phi_c - phi) - t_c) to first order, so the current pose enters through phi only.
      const Eigen::MatrixXd H_p = c.H_landmark * se3::hat(p_world);
      c.H_pose.rightCols<3>() = -H_p;
      c.H_clone = Eigen::MatrixXd::Zero(r, kPoseDim);
      c.H_clone.leftCols<3>() = -c.H_landmark;
      c.H_clone.rightCols<3>() = H_p;
    } else if (correct_pose) {
      c.H_pose.leftCols<3>() = -c.H_landmark;
    }
    // S_i = H_i Sigma_[pose, calibration, (clone,) landmark] H_i^T + R.
    const int ni = 9 + nc + (clone_columns ? kPoseDim : 0);
    Eigen::MatrixXd Hi(r, ni);
    std::array<int, 17> index{};
    int used = 0;
    for (int a = 0; a < 6; ++a) index[used++] = a;
    for (int a = 0; a < nc; ++a) index[used++] = calibration_row + a;
    if (clone_columns) {
      for (int a = 0; a < kPoseDim; ++a) index[used++] = clone_row + a;
      Hi << c.H_pose, c.H_calibration, c.H_clone, c.H_landmark;
    } else {
      Hi << c.H_pose, c.H_calibration, c.H_landmark;
    }
    for (int a = 0; a < 3; ++a) index[used++] = row + a;
    Eigen::MatrixXd sub(ni, ni);
    for (int a = 0; a < ni; ++a) {
      for (int b = 0; b < ni; ++b) sub(a, b) = S(index[a], index[b]);
    }
    Eigen::MatrixXd Si = Hi * sub * Hi.transpose();
    Si.diagonal().array() += pixel_var;
    c.mahalanobis2 = c.residual.dot(Si.ldlt().solve(c.residual));
  }
  detectJumps(candidates);

  for (Candidate& c : *candidates) {
    if (!c.predicted) continue;
    if (c.jumped) {
      // The track slid onto another point, or this observation is a gross outlier: the landmark
      // leaves the state (its estimate stays in the map) and the track goes on as a new landmark
      // from its next observation (starting from this one would plant an outlier in the map).
      remove_for_jump.push_back(c.block);
      continue;
    }
    const double d2 = c.mahalanobis2;
    if (!(d2 <= gate_threshold_)) {
      stats_.increment(Counter::kObsGated);
      ++result->observations_rejected;
      // A landmark known from one observation may have been started by an outlier, and a track
      // that keeps failing the gate has jumped (seen in the KITTI tracks): restart either from
      // its current observation instead of gating the rest of its track away.
      StateBlock& block = blocks_[c.block];
      block.has_flow_reference = false;
      // Only gross disagreement counts towards a restart: chance gatings of a good track (5 % at
      // a 95 % gate) must not throw its accumulated information away.
      if (d2 > restart_threshold_) ++block.consecutive_gated;
      const bool restart = map_[block.map_index].observations <= 1 ||
                           (options_.reinitialize_after_gated > 0 &&
                            block.consecutive_gated >= options_.reinitialize_after_gated);
      if (restart) {
        remove_for_reinit.push_back(c.block);
        reinitialize->push_back(c);
        reinitialize->back().reuse_map_index = block.map_index;
      }
      continue;
    }
    blocks_[c.block].consecutive_gated = 0;
    if (options_.max_track_length > 0 && blocks_[c.block].frames > options_.max_track_length) {
      // Long track (real tracks drift off their point): the landmark leaves the state and the
      // track goes on as a new landmark (new map entry) from this observation, which has just
      // passed the gate, so an outlier never starts the new segment.
      remove_for_split.push_back(c.block);
      reinitialize->push_back(c);
      continue;
    }
    accepted.push_back(&c);
  }

  if (!accepted.empty()) {
    const int n = static_cast<int>(accepted.size());
    const int m = r * n;
    // P H^T (dim x m), using the sparsity of H: each observation touches pose + one landmark.
    Eigen::MatrixXd PHt(dim_, m);
    for (int k = 0; k < n; ++k) {
      const Candidate& c = *accepted[k];
      const int row = landmarkRow(c.block);
      PHt.middleCols(k * r, r).noalias() = S.middleCols(row, 3) * c.H_landmark.transpose();
      if (correct_pose) PHt.middleCols(k * r, r).noalias() += S.leftCols<6>() * c.H_pose.transpose();
      if (c.via_clone && clone_dim_ > 0) {
        PHt.middleCols(k * r, r).noalias() +=
            S.middleCols(clone_row, kPoseDim) * c.H_clone.transpose();
      }
      if (nc > 0) {
        PHt.middleCols(k * r, r).noalias() +=
            S.middleCols(calibration_row, nc) * c.H_calibration.transpose();
      }
    }
    // Innovation covariance H P H^T + R (m x m).
    Eigen::MatrixXd innovation_cov(m, m);
    Eigen::VectorXd residual(m);
    for (int k = 0; k < n; ++k) {
      const Candidate& c = *accepted[k];
      const int row = landmarkRow(c.block);
      innovation_cov.middleRows(k * r, r).noalias() = c.H_landmark * PHt.middleRows(row, 3);
      if (correct_pose) innovation_cov.middleRows(k * r, r).noalias() += c.H_pose * PHt.topRows<6>();
      if (c.via_clone && clone_dim_ > 0) {
        innovation_cov.middleRows(k * r, r).noalias() +=
            c.H_clone * PHt.middleRows(clone_row, kPoseDim);
      }
      if (nc > 0) {
        innovation_cov.middleRows(k * r, r).noalias() +=
            c.H_calibration * PHt.middleRows(calibration_row, nc);
      }
      residual.segment(k * r, r) = c.residual;
    }
    innovation_cov.diagonal().array() += pixel_var;
    Eigen::LLT<Eigen::MatrixXd> llt(innovation_cov);
    if (llt.info() != Eigen::Success) {
      stats_.increment(Counter::kUpdateNonFinite);
      result->message = "innovation covariance not positive definite: update skipped";
    } else {
      // B = L^-1 (P H^T)^T; dx = B^T L^-1 r; Sigma -= B^T B (symmetric by construction).
      const Eigen::MatrixXd B = llt.matrixL().solve(PHt.transpose());
      const Eigen::VectorXd w = llt.matrixL().solve(residual);
      const Eigen::VectorXd dx = B.transpose() * w;
      if (!dx.allFinite() || !B.allFinite()) {
        stats_.increment(Counter::kUpdateNonFinite);
        result->message = "update produced non-finite numbers: discarded";
      } else {
        S.selfadjointView<Eigen::Lower>().rankUpdate(B.transpose(), -1.0);
        for (int j = 1; j < dim_; ++j) S.col(j).head(j) = S.row(j).head(j).transpose();
        if (correct_pose) {
          // world_T_imu <- exp(eps^) world_T_imu  <=>  imu_T_world <- imu_T_world exp(-eps^).
          imu_T_world_ = imu_T_world_ * se3::exp(-dx.head<6>());
          se3::normalizeRotation(&imu_T_world_);
        }
        if (clone_dim_ > 0) {
          imu_T_world_clone_ = imu_T_world_clone_ * se3::exp(-dx.segment<6>(clone_row));
          se3::normalizeRotation(&imu_T_world_clone_);
        }
        if (bias_dim_ > 0) bias_ += dx.segment(kPoseDim, bias_dim_);
        if (rotation_dim_ > 0) {
          imu_R_twist_ = se3::expSO3(dx.segment<3>(kPoseDim + bias_dim_)) * imu_R_twist_;
        }
        if (disparity_dim_ > 0) disparity_offset_ += dx(disparityRow());
        if (scale_dim_ > 0) {
          baseline_scale_error_ += dx(scaleRow());
          applyBaselineScale();
        }
        // Landmarks: p <- exp(dphi^) p + J_l(dphi) dxi (the SE_K(3) exponential).
        const Eigen::Vector3d dphi = correct_pose ? Eigen::Vector3d(dx.segment<3>(3))
                                                  : Eigen::Vector3d::Zero();
        const Eigen::Matrix3d R = se3::expSO3(dphi);
        const Eigen::Matrix3d J = se3::leftJacobianSO3(dphi);
        for (size_t k = 0; k < blocks_.size(); ++k) {
          const int row = landmarkRow(k);
          p_world_.segment<3>(row) = R * p_world_.segment<3>(row) + J * dx.segment<3>(row);
        }
        for (const Candidate* c : accepted) ++map_[blocks_[c->block].map_index].observations;
        stats_.increment(Counter::kObservationUpdate, n);
        result->observations_updated += n;
        // Guard: the diagonal must stay positive.
        if (!(S.diagonal().array() > 0.0).all()) {
          stats_.increment(Counter::kCovarianceRepaired);
          S.diagonal() = S.diagonal().cwiseMax(1e-12);
        }
      }
    }
  }

  for (const Candidate* c : accepted) setFlowReference(c->block, c->feature);

  if (!remove_for_reinit.empty() || !remove_for_split.empty() || !remove_for_jump.empty()) {
    std::vector<bool> remove(blocks_.size(), false);
    for (size_t b : remove_for_reinit) remove[b] = true;
    for (size_t b : remove_for_split) remove[b] = true;
    for (size_t b : remove_for_jump) remove[b] = true;
    removeBlocks(remove, /*count_as_marginalized=*/false);
    const size_t ended = remove_for_split.size() + remove_for_jump.size();
    stats_.increment(Counter::kLandmarkReinitialized, remove_for_reinit.size());
    stats_.increment(Counter::kLandmarkSplit, remove_for_split.size());
    stats_.increment(Counter::kLandmarkJump, remove_for_jump.size());
    stats_.increment(Counter::kLandmarkMarginalized, ended);
    result->landmarks_marginalized += static_cast<int>(ended);
  }
}

void VislamEstimator::detectJumps(std::vector<Candidate>* candidates) {
  if (options_.jump_threshold_px <= 0.0) return;
  if (jump_test_paused_) {
    jump_test_paused_ = false;
    return;
  }
  auto S = sigma_.topLeftCorner(dim_, dim_);
  std::vector<FlowCheck> checks;
  std::vector<Candidate*> checked;
  checks.reserve(candidates->size());
  checked.reserve(candidates->size());
  for (Candidate& c : *candidates) {
    const StateBlock& block = blocks_[c.block];
    if (!c.predicted || !block.has_flow_reference) continue;
    const int row = landmarkRow(c.block);
    FlowCheck check;
    check.residual_change = c.residual.head<2>() - block.flow_residual;
    // Pose error exp(eps^) world_T_imu with the landmark fixed: d p_world = -rho - phi x p.
    const Eigen::Matrix<double, 2, 3> H = c.H_landmark.topRows<2>();
    check.H_pose.leftCols<3>() = -H;
    check.H_pose.rightCols<3>() = H * se3::hat(Eigen::Vector3d(p_world_.segment<3>(row)));
    // The landmark's own error moves both predictions: (H_now - H_before) Sigma_l (...)^T.
    const Eigen::Matrix<double, 2, 3> D = H - block.flow_H_landmark;
    check.landmark_variance = (D * S.block<3, 3>(row, row) * D.transpose()).diagonal();
    checks.push_back(check);
    checked.push_back(&c);
  }
  TrackJumpOptions jump_options;
  jump_options.threshold_px = options_.jump_threshold_px;
  jump_options.threshold_sigmas = options_.jump_threshold_sigmas;
  const TrackJumpResult jumps = detectTrackJumps(checks, jump_options);
  for (size_t i = 0; i < checked.size(); ++i) checked[i]->jumped = jumps.jumped[i];
}

void VislamEstimator::setFlowReference(size_t block, const StereoObservation& f) {
  StateBlock& b = blocks_[block];
  Eigen::Vector4d z_pred;
  Matrix43d H_landmark;
  b.has_flow_reference = camera_.project(imu_T_world_, p_world_.segment<3>(landmarkRow(block)),
                                         &z_pred, nullptr, &H_landmark, options_.min_depth * 0.5);
  if (!b.has_flow_reference) return;
  // Rows uL and v of the observation (the first two of observationSelector in either layout).
  const Eigen::Matrix<double, 2, 4> M2 = observation_selector_.topRows<2>();
  const Eigen::Vector4d z(f.u_left, f.v_left, f.u_right, f.v_right);
  b.flow_residual = M2 * (z - z_pred);
  b.flow_H_landmark = M2 * H_landmark;
}

bool VislamEstimator::initializeLandmark(const Candidate& c, double stamp, FeedResult* result) {
  const StereoObservation& f = c.feature;
  const double v = options_.merge_stereo_rows ? 0.5 * (f.v_left + f.v_right) : f.v_left;
  Eigen::Vector3d p_cam;
  Eigen::Matrix3d J_uvu;
  // Measured uR = true uR - offset.
  if (!camera_.triangulate(f.u_left, v, f.u_right + disparity_offset_, &p_cam, &J_uvu)) {
    stats_.increment(Counter::kObsDisparity);
    ++result->observations_rejected;
    return false;
  }
  if (p_cam.z() < options_.min_depth || p_cam.z() > options_.max_depth) {
    stats_.increment(Counter::kObsDepth);
    ++result->observations_rejected;
    return false;
  }
  const Eigen::Matrix4d& imu_T_cam = camera_.imuTCam();
  const Eigen::Vector3d p_imu = imu_T_cam.topLeftCorner<3, 3>() * p_cam + imu_T_cam.topRightCorner<3, 1>();
  const Eigen::Matrix3d R_world_imu = imu_T_world_.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d p_world =
      R_world_imu * (p_imu - imu_T_world_.topRightCorner<3, 1>());

  const double pixel_var = options_.pixel_sigma * options_.pixel_sigma;
  const Eigen::Matrix3d J_z = R_world_imu * imu_T_cam.topLeftCorner<3, 3>() * J_uvu;
  Eigen::Matrix3d sigma_ll = pixel_var * J_z * J_z.transpose();

  const int row = dim_;
  ensureCapacity(dim_ + 3);
  auto S = sigma_.topLeftCorner(dim_ + 3, dim_ + 3);
  // Error of the new landmark as a function of the state error: in SLAM mode the invariant error
  // xi = p_true - exp(phi^) p_mean = rho + R dp_imu to first order (correlated through rho), and
  // the triangulation also depends on the calibration states: A = d xi / d state. Only the
  // pose and auxiliary columns of A can be non-zero, so A is kept to those (3 x head): the cross
  // covariance costs O(head dim), not O(dim^2).
  const int head = kPoseDim + auxDim();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3, head);
  if (options_.mode == EstimatorMode::kSlam) A.leftCols<3>().setIdentity();
  if (disparity_dim_ > 0) {
    // Element-wise: GCC 12 reports a false -Warray-bounds on a vectorized 3-vector copy here.
    for (int i = 0; i < 3; ++i) A(i, disparityRow()) = J_z(i, 2);
  }
  if (scale_dim_ > 0) {
    // Every coordinate of the triangulated point scales with the baseline.
    const Eigen::Vector3d dp_dbeta =
        R_world_imu * imu_T_cam.topLeftCorner<3, 3>() * p_cam / (1.0 + baseline_scale_error_);
    for (int i = 0; i < 3; ++i) A(i, scaleRow()) = dp_dbeta(i);
  }
  const Eigen::MatrixXd cross = A * S.topLeftCorner(head, dim_);  // Cov(xi, state)
  S.block(row, 0, 3, dim_) = cross;
  S.block(0, row, dim_, 3) = cross.transpose();
  sigma_ll += cross.leftCols(head) * A.transpose();
  S.block<3, 3>(row, row) = sigma_ll;
  p_world_.segment<3>(row) = p_world;
  dim_ += 3;

  const bool reuse = c.reuse_map_index < map_.size();
  LandmarkEstimate& estimate = reuse ? map_[c.reuse_map_index] : map_.emplace_back();
  estimate.id = f.id;
  estimate.p_world = p_world;
  estimate.covariance = landmarkCovariance(blocks_.size());
  estimate.observations = 1;
  estimate.active = true;
  estimate.first_stamp = estimate.last_stamp = stamp;
  blocks_.push_back(StateBlock{reuse ? c.reuse_map_index : map_.size() - 1, true});
  tracking_[f.id] = blocks_.size() - 1;
  setFlowReference(blocks_.size() - 1, f);
  stats_.increment(Counter::kLandmarkInitialized);
  stats_.increment(Counter::kObservationInitialized);
  ++result->landmarks_initialized;
  return true;
}

Eigen::Matrix3d VislamEstimator::landmarkCovariance(size_t block) const {
  const int row = landmarkRow(block);
  if (options_.mode != EstimatorMode::kSlam) return sigma_.block<3, 3>(row, row);
  // dp = xi - p^ phi.
  Eigen::Matrix<double, 3, 6> M;
  M.leftCols<3>() = -se3::hat(Eigen::Vector3d(p_world_.segment<3>(row)));
  M.rightCols<3>().setIdentity();
  Eigen::Matrix<double, 6, 6> joint;
  joint.topLeftCorner<3, 3>() = sigma_.block<3, 3>(3, 3);
  joint.topRightCorner<3, 3>() = sigma_.block<3, 3>(3, row);
  joint.bottomLeftCorner<3, 3>() = sigma_.block<3, 3>(row, 3);
  joint.bottomRightCorner<3, 3>() = sigma_.block<3, 3>(row, row);
  return M * joint * M.transpose();
}

void VislamEstimator::syncBlockToMap(size_t block) {
  LandmarkEstimate& l = map_[blocks_[block].map_index];
  l.p_world = p_world_.segment<3>(landmarkRow(block));
  l.covariance = landmarkCovariance(block);
}

void VislamEstimator::syncBlocksToMap() {
  for (size_t k = 0; k < blocks_.size(); ++k) {
    syncBlockToMap(k);
    LandmarkEstimate& l = map_[blocks_[k].map_index];
    l.active = true;
    if (blocks_[k].tracking && blocks_[k].frames_absent == 0) l.last_stamp = time_;
  }
}

void VislamEstimator::removeBlocks(const std::vector<bool>& remove, bool count_as_marginalized) {
  // Only the leaving blocks need their final estimate in the map now (the others are synced at
  // the end of the frame); last_stamp stays the last frame the track was seen in.
  for (size_t k = 0; k < blocks_.size(); ++k) {
    if (remove[k]) syncBlockToMap(k);
  }
  std::vector<int> keep_rows;
  keep_rows.reserve(dim_);
  for (int i = 0; i < headDim(); ++i) keep_rows.push_back(i);
  std::vector<StateBlock> kept_blocks;
  for (size_t k = 0; k < blocks_.size(); ++k) {
    if (remove[k]) {
      LandmarkEstimate& l = map_[blocks_[k].map_index];
      l.active = false;
      tracking_.erase(l.id);
      if (count_as_marginalized) stats_.increment(Counter::kLandmarkMarginalized);
      continue;
    }
    const int row = landmarkRow(k);
    for (int i = 0; i < 3; ++i) keep_rows.push_back(row + i);
    kept_blocks.push_back(blocks_[k]);
  }
  // Compact in place: new indices never exceed old ones, so ascending copies are safe.
  const int new_dim = static_cast<int>(keep_rows.size());
  for (int c = 0; c < new_dim; ++c) {
    if (keep_rows[c] != c) sigma_.col(c).head(dim_) = sigma_.col(keep_rows[c]).head(dim_);
  }
  for (int c = 0; c < new_dim; ++c) {
    for (int r = 0; r < new_dim; ++r) {
      if (keep_rows[r] != r) sigma_(r, c) = sigma_(keep_rows[r], c);
    }
  }
  for (int r = 0; r < new_dim; ++r) {
    p_world_(r) = p_world_(keep_rows[r]);
  }
  dim_ = new_dim;
  blocks_.swap(kept_blocks);
  // Give memory back after a burst (a frame with thousands of new landmarks).
  const int capacity = static_cast<int>(sigma_.rows());
  if (capacity > 256 && dim_ < capacity / 4) {
    const int new_capacity = std::max(64, 2 * dim_);
    Eigen::MatrixXd shrunk = sigma_.topLeftCorner(new_capacity, new_capacity);
    sigma_.swap(shrunk);
    Eigen::VectorXd shrunk_mean = p_world_.head(new_capacity);
    p_world_.swap(shrunk_mean);
  }
  tracking_.clear();
  for (size_t k = 0; k < blocks_.size(); ++k) {
    if (blocks_[k].tracking) tracking_[map_[blocks_[k].map_index].id] = k;
  }
}

// ---------------------------------------------------------------------------------------------
// Health
// ---------------------------------------------------------------------------------------------

double VislamEstimator::positionSigma() const {
  // Of the position in world axes (the internal rho also carries rotation error x distance).
  return std::sqrt(poseCovarianceWorld().diagonal().head<3>().maxCoeff());
}

void VislamEstimator::checkHealth(int candidates, int gated, FeedResult* result) {
  if (candidates >= 10 && gated > options_.rejected_fraction * candidates) {
    ++consecutive_rejected_frames_;
  } else {
    consecutive_rejected_frames_ = 0;
  }
  const double position_sigma = positionSigma();
  if (!std::isfinite(position_sigma) || position_sigma > options_.max_position_sigma) {
    std::ostringstream why;
    why << "pose covariance blew up (position sigma " << position_sigma << " m > health/max_position_sigma)";
    recoverFromDivergence(why.str(), result);
  } else if (consecutive_rejected_frames_ >= options_.max_rejected_frames) {
    std::ostringstream why;
    why << consecutive_rejected_frames_ << " consecutive frames with most observations gated";
    recoverFromDivergence(why.str(), result);
  }
}

void VislamEstimator::recoverFromDivergence(const std::string& why, FeedResult* result) {
  stats_.increment(Counter::kDivergenceRecovery);
  consecutive_rejected_frames_ = 0;
  removeBlocks(std::vector<bool>(blocks_.size(), true));
  if (options_.divergence_policy == DivergencePolicy::kResetFilter) {
    bias_.setZero();
    setPriorCovariance();
    result->message = "divergence: " + why + "; filter restarted at the current pose";
  } else {
    // Keep the pose and bias estimates; their covariance must stay finite and bounded.
    if (!sigma_.topLeftCorner(dim_, dim_).allFinite() ||
        !(positionSigma() <= options_.max_position_sigma)) {
      setPriorCovariance();
    }
    result->message = "divergence: " + why + "; landmarks dropped from the state";
  }
}

// ---------------------------------------------------------------------------------------------
// Outputs
// ---------------------------------------------------------------------------------------------

Eigen::Isometry3d VislamEstimator::worldTImu() const {
  return Eigen::Isometry3d(se3::inverse(imu_T_world_));
}

Matrix6d VislamEstimator::poseCovarianceWorld() const {
  // exp(eps^) T: position p + rho + phi x p, rotation exp(phi) R. In (delta p, delta theta):
  // M = [[I, -p^], [0, I]].
  const Eigen::Vector3d p = worldTImu().translation();
  Matrix6d M = Matrix6d::Identity();
  M.topRightCorner<3, 3>() = -se3::hat(p);
  const Matrix6d pose = sigma_.topLeftCorner<6, 6>();
  return M * pose * M.transpose();
}

TwistData VislamEstimator::correctedTwist() const {
  TwistData t = held_twist_;
  const Vector6d u = trueTwist(held_twist_);
  t.v_imu = u.head<3>();
  t.w_imu = u.tail<3>();
  return t;
}

Matrix6d VislamEstimator::correctedTwistCovariance() const {
  Matrix6d cov = twistNoiseDensity(held_twist_) / std::max(1e-3, last_twist_dt_);
  for (int i = 0; i < bias_dim_; ++i) {
    for (int j = 0; j < bias_dim_; ++j) {
      cov(bias_components_[i], bias_components_[j]) +=
          sigma_(kPoseDim + i, kPoseDim + j);
    }
  }
  return cov;
}

Vector6d VislamEstimator::twistBias() const { return biasVector(); }

double VislamEstimator::baselineScaleSigma() const {
  return scale_dim_ > 0 ? std::sqrt(sigma_(scaleRow(), scaleRow())) : 0.0;
}

double VislamEstimator::disparityOffsetSigma() const {
  return disparity_dim_ > 0 ? std::sqrt(sigma_(disparityRow(), disparityRow())) : 0.0;
}

}  // namespace ekf_vislam
