#include "ekf_vislam/core/filter_state.h"

#include "ekf_vislam/core/inverse_depth_retraction.h"
#include "ekf_vislam/core/se3.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

namespace ekf_vislam {

FilterState::FilterState(StateLayout layout) : layout_(std::move(layout)) {}

void FilterState::reset(const StatePrior& prior) {
  deferred_.steps = 0;  // those of the state before: gone with it
  imu_T_world.setIdentity();
  imu_T_world_clone.setIdentity();
  bias = Eigen::VectorXd::Zero(layout_.biasDim());
  speed_scale_error = 0.0;
  imu_R_twist.setIdentity();
  disparity_offset = 0.0;
  baseline_scale_error = 0.0;
  track_drift_rate_imu.setZero();
  road_tilt_world.setZero();
  gravity_level_world.setZero();
  accel_bias_imu.setZero();
  dim_ = layout_.headDim();
  const int capacity = std::max(64, dim_);
  sigma_ = Eigen::MatrixXd::Zero(capacity, capacity);
  if (layout_.reported_covariance) sigma_reported_ = Eigen::MatrixXd::Zero(capacity, capacity);
  track_noise_carried_ = layout_.reported_covariance;
  track_noise_ =
      track_noise_carried_ ? Eigen::MatrixXd::Zero(capacity, capacity) : Eigen::MatrixXd();
  landmark_means_ = Eigen::VectorXd::Zero(capacity);
  setPrior(prior);
}

void FilterState::setPrior(const StatePrior& prior) {
  auto S = covariance();
  S.setZero();
  noise_since_update_.setZero();
  const double p2 = prior.position_sigma * prior.position_sigma;
  const double r2 = prior.rotation_sigma * prior.rotation_sigma;
  // The prior is isotropic in (delta p, delta theta) about the current position; the internal
  // world-frame error has rho = delta p - phi x p, i.e. Sigma = M^-1 diag M^-T, M^-1 = [[I, p^],
  // [0, I]] (the identity at the origin).
  Matrix6d M_inv = Matrix6d::Identity();
  const Eigen::Vector3d p_imu_world = se3::inverse(imu_T_world).topRightCorner<3, 1>();
  M_inv.topRightCorner<3, 3>() = se3::hat(p_imu_world);
  Vector6d diagonal;
  diagonal << p2, p2, p2, r2, r2, r2;
  sigma_.topLeftCorner<6, 6>() = M_inv * diagonal.asDiagonal() * M_inv.transpose();
  for (int i = 0; i < layout_.biasDim(); ++i) {
    const double s =
        layout_.bias_components[i] < 3 ? prior.velocity_bias_sigma : prior.gyro_bias_sigma;
    const int row = layout_.biasRow() + i;
    sigma_(row, row) = s * s;
  }
  // A variable only counted, not estimated, has its prior in the reported covariance alone (set
  // below, after the copy): the gains' covariance, and so the estimate, never see it.
  std::vector<std::pair<int, double>> reported_only;
  const auto setPriorVariance = [&](int row, double sigma, bool counted_only) {
    if (counted_only && layout_.reported_covariance) {
      reported_only.emplace_back(row, sigma * sigma);
    } else {
      sigma_(row, row) = sigma * sigma;
    }
  };
  if (layout_.speed_scale_dim > 0) {
    setPriorVariance(layout_.speedScaleRow(), prior.speed_scale_sigma,
                     prior.speed_scale_reported_only);
  }
  for (int i = 0; i < layout_.rotation_dim; ++i) {
    const int row = layout_.rotationRow() + i;
    sigma_(row, row) = prior.twist_rotation_sigma * prior.twist_rotation_sigma;
  }
  if (layout_.disparity_dim > 0) {
    setPriorVariance(layout_.disparityRow(), prior.disparity_offset_sigma,
                     prior.disparity_offset_reported_only);
  }
  if (layout_.scale_dim > 0) {
    const int row = layout_.scaleRow();
    sigma_(row, row) = prior.baseline_scale_sigma * prior.baseline_scale_sigma;
  }
  for (int i = 0; i < layout_.drift_dim; ++i) {
    const int row = layout_.driftRow() + i;
    sigma_(row, row) = prior.track_drift_rate_sigma * prior.track_drift_rate_sigma;
  }
  if (layout_.tilt_dim > 0) {
    // The road is taken to be under the vehicle as it stands now.
    road_tilt_world = se3::inverse(imu_T_world).block<2, 1>(0, 2);
    for (int i = 0; i < layout_.tilt_dim; ++i) {
      const int row = layout_.tiltRow() + i;
      sigma_(row, row) = prior.road_tilt_sigma * prior.road_tilt_sigma;
    }
  }
  if (layout_.gravity_dim > 0) {
    for (int i = 0; i < 2; ++i) {
      const int row = layout_.levelRow() + i;
      sigma_(row, row) = prior.level_sigma * prior.level_sigma;
    }
    for (int i = 0; i < 3; ++i) {
      const int row = layout_.accelBiasRow() + i;
      sigma_(row, row) = prior.accel_bias_sigma * prior.accel_bias_sigma;
    }
  }
  if (layout_.reported_covariance) {
    covariance(1) = sigma_.topLeftCorner(dim_, dim_);
    for (const auto& [row, variance] : reported_only) sigma_reported_(row, row) = variance;
  }
  if (track_noise_carried_) covariance(kTrackNoise).setZero();
  clonePose();
}

Vector6d FilterState::biasVector() const {
  Vector6d b = Vector6d::Zero();
  for (int i = 0; i < layout_.biasDim(); ++i) b(layout_.bias_components[i]) = bias(i);
  return b;
}

void FilterState::clonePose() {
  imu_T_world_clone = imu_T_world;
  if (layout_.clone_dim == 0) return;
  // The clone's error equals the pose error now: rows, then columns (which sets the clone block
  // to the pose block).
  const int c = layout_.cloneRow();
  for (int which = 0; which < carriedCount(); ++which) {
    auto S = covariance(which);
    S.middleRows(c, StateLayout::kPoseDim) = S.topRows(StateLayout::kPoseDim);
    S.middleCols(c, StateLayout::kPoseDim) = S.leftCols(StateLayout::kPoseDim);
  }
}

void FilterState::ensureCapacity(int dim) {
  const int capacity = static_cast<int>(sigma_.rows());
  if (dim <= capacity) return;
  const int new_capacity = std::max(dim, 2 * capacity);
  for (int which = 0; which < carriedCount(); ++which) {
    Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(new_capacity, new_capacity);
    grown.topLeftCorner(dim_, dim_) = storage(which).topLeftCorner(dim_, dim_);
    storage(which).swap(grown);
  }
  Eigen::VectorXd grown_mean = Eigen::VectorXd::Zero(new_capacity);
  grown_mean.head(dim_) = landmark_means_.head(dim_);
  landmark_means_.swap(grown_mean);
}

void FilterState::appendLandmark(const Eigen::Vector3d& p_world,
                                 const Eigen::MatrixXd& cross_covariance,
                                 const Eigen::Matrix3d& own_covariance) {
  const auto count = static_cast<size_t>(covarianceCount());
  appendLandmark(p_world, std::vector<Eigen::MatrixXd>(count, cross_covariance),
                 std::vector<Eigen::Matrix3d>(count, own_covariance));
}

void FilterState::appendLandmark(const Eigen::Vector3d& p_world,
                                 const std::vector<Eigen::MatrixXd>& cross_covariances,
                                 const std::vector<Eigen::Matrix3d>& own_covariances) {
  applyDeferredPredictions();
  const int row = dim_;
  ensureCapacity(dim_ + 3);
  for (int which = 0; which < carriedCount(); ++which) {
    auto S = storage(which).topLeftCorner(dim_ + 3, dim_ + 3);
    if (static_cast<size_t>(which) >= cross_covariances.size()) {  // a part not given: zero
      S.middleRows(row, 3).setZero();
      S.middleCols(row, 3).setZero();
      continue;
    }
    S.block(row, 0, 3, dim_) = cross_covariances[which];
    S.block(0, row, dim_, 3) = cross_covariances[which].transpose();
    S.block<3, 3>(row, row) = own_covariances[which];
  }
  landmark_means_.segment<3>(row) = p_world;
  dim_ += 3;
}

void FilterState::addGravityRows(double level_sigma, double accel_bias_sigma) {
  if (layout_.gravity_dim > 0) return;
  applyDeferredPredictions();  // its sums are sized by the auxiliary rows
  constexpr int kRows = 5;
  const int insert = layout_.cloneRow();  // the gravity rows end the auxiliary ones
  const int tail = dim_ - insert;
  ensureCapacity(dim_ + kRows);
  for (int which = 0; which < carriedCount(); ++which) {
    Eigen::MatrixXd& sigma = storage(which);
    const Eigen::MatrixXd old = sigma.topLeftCorner(dim_, dim_);
    auto S = sigma.topLeftCorner(dim_ + kRows, dim_ + kRows);
    S.setZero();
    S.topLeftCorner(insert, insert) = old.topLeftCorner(insert, insert);
    S.block(0, insert + kRows, insert, tail) = old.topRightCorner(insert, tail);
    S.block(insert + kRows, 0, tail, insert) = old.bottomLeftCorner(tail, insert);
    S.bottomRightCorner(tail, tail) = old.bottomRightCorner(tail, tail);
    for (int i = 0; i < kRows && which < covarianceCount(); ++i) {
      const double s = i < 2 ? level_sigma : accel_bias_sigma;
      S(insert + i, insert + i) = s * s;
    }
  }
  const Eigen::VectorXd means = landmark_means_.segment(insert, tail);
  landmark_means_.segment(insert, kRows).setZero();
  landmark_means_.segment(insert + kRows, tail) = means;
  layout_.gravity_dim = kRows;
  dim_ += kRows;
  gravity_level_world.setZero();
  accel_bias_imu.setZero();
}

void FilterState::keepRows(const std::vector<int>& rows) {
  applyDeferredPredictions();
  // New indices never exceed old ones, so ascending copies are safe.
  const int new_dim = static_cast<int>(rows.size());
  for (int which = 0; which < carriedCount(); ++which) {
    Eigen::MatrixXd& sigma = storage(which);
    for (int c = 0; c < new_dim; ++c) {
      if (rows[c] != c) sigma.col(c).head(dim_) = sigma.col(rows[c]).head(dim_);
    }
    for (int c = 0; c < new_dim; ++c) {
      for (int r = 0; r < new_dim; ++r) {
        if (rows[r] != r) sigma(r, c) = sigma(rows[r], c);
      }
    }
  }
  for (int r = 0; r < new_dim; ++r) landmark_means_(r) = landmark_means_(rows[r]);
  dim_ = new_dim;
  // Give memory back after a burst (a frame with thousands of new landmarks).
  const int capacity = static_cast<int>(sigma_.rows());
  if (capacity > 256 && dim_ < capacity / 4) {
    const int new_capacity = std::max(64, 2 * dim_);
    for (int which = 0; which < carriedCount(); ++which) {
      Eigen::MatrixXd shrunk = storage(which).topLeftCorner(new_capacity, new_capacity);
      storage(which).swap(shrunk);
    }
    Eigen::VectorXd shrunk_mean = landmark_means_.head(new_capacity);
    landmark_means_.swap(shrunk_mean);
  }
}

namespace {

/// What takes a landmark from its world-line move (the SE_K(3) exponential) onto its
/// inverse-depth line in the camera (inverse_depth_retraction.h), in world axes. Seen from the
/// pose, the exponential moves the landmark by dq = cam_R_imu R_before^T J_r(dphi) (dxi - drho)
/// (camera axes, R_before = world_R_imu before the correction; J_r = exp(-dphi^) J_l).
class InverseDepthBend {
 public:
  InverseDepthBend(const Eigen::Matrix4d& cam_T_imu, const Eigen::Matrix4d& imu_T_world_before,
                   const Eigen::Matrix4d& imu_T_world_after, const Eigen::Matrix3d& R,
                   const Eigen::Matrix3d& J, const Eigen::Vector3d& drho)
      : cam_T_world_before_(cam_T_imu * imu_T_world_before),
        to_camera_(cam_T_world_before_.topLeftCorner<3, 3>() * R.transpose() * J),
        world_R_cam_after_(imu_T_world_after.topLeftCorner<3, 3>().transpose() *
                           cam_T_imu.topLeftCorner<3, 3>().transpose()),
        drho_(drho) {}

  Eigen::Vector3d operator()(const Eigen::Vector3d& p_before, const Eigen::Vector3d& dxi) const {
    const Eigen::Vector3d dq = to_camera_ * (dxi - drho_);
    const Eigen::Vector3d q = cam_T_world_before_.topLeftCorner<3, 3>() * p_before +
                              cam_T_world_before_.topRightCorner<3, 1>();
    return world_R_cam_after_ * (inverse_depth_retraction::move(q, dq) - (q + dq));
  }

 private:
  Eigen::Matrix4d cam_T_world_before_;
  Eigen::Matrix3d to_camera_;
  Eigen::Matrix3d world_R_cam_after_;
  Eigen::Vector3d drho_;
};

}  // namespace

void FilterState::applyCorrection(const Eigen::VectorXd& dx, bool correct_pose) {
  applyDeferredPredictions();  // D holds the landmark means
  const StateLayout& L = layout_;
  const Eigen::Matrix4d imu_T_world_before = imu_T_world;
  if (correct_pose) {
    // world_T_imu <- exp(eps^) world_T_imu  <=>  imu_T_world <- imu_T_world exp(-eps^).
    imu_T_world = imu_T_world * se3::exp(-dx.head<6>());
    se3::normalizeRotation(&imu_T_world);
  }
  if (L.clone_dim > 0) {
    imu_T_world_clone = imu_T_world_clone * se3::exp(-dx.segment<6>(L.cloneRow()));
    se3::normalizeRotation(&imu_T_world_clone);
  }
  if (L.biasDim() > 0) bias += dx.segment(L.biasRow(), L.biasDim());
  if (L.speed_scale_dim > 0) speed_scale_error += dx(L.speedScaleRow());
  if (L.rotation_dim > 0) imu_R_twist = se3::expSO3(dx.segment<3>(L.rotationRow())) * imu_R_twist;
  if (L.disparity_dim > 0) disparity_offset += dx(L.disparityRow());
  if (L.scale_dim > 0) baseline_scale_error += dx(L.scaleRow());
  if (L.drift_dim > 0) track_drift_rate_imu += dx.segment<3>(L.driftRow());
  if (L.tilt_dim > 0) road_tilt_world += dx.segment<2>(L.tiltRow());
  if (L.gravity_dim > 0) {
    gravity_level_world += dx.segment<2>(L.levelRow());
    accel_bias_imu += dx.segment<3>(L.accelBiasRow());
  }
  // Landmarks: p <- exp(dphi^) p + J_l(dphi) dxi (the SE_K(3) exponential), bent onto the
  // inverse-depth line when inverse_depth_cam_T_imu is set.
  const Eigen::Vector3d dphi =
      correct_pose ? Eigen::Vector3d(dx.segment<3>(3)) : Eigen::Vector3d::Zero();
  const Eigen::Matrix3d R = se3::expSO3(dphi);
  const Eigen::Matrix3d J = se3::leftJacobianSO3(dphi);
  std::optional<InverseDepthBend> bend;
  if (inverse_depth_cam_T_imu) {
    const Eigen::Vector3d drho =
        correct_pose ? Eigen::Vector3d(dx.head<3>()) : Eigen::Vector3d::Zero();
    bend.emplace(*inverse_depth_cam_T_imu, imu_T_world_before, imu_T_world, R, J, drho);
  }
  for (int row = L.headDim(); row < dim_; row += 3) {
    const Eigen::Vector3d p_before = landmark_means_.segment<3>(row);
    const Eigen::Vector3d dxi = dx.segment<3>(row);
    Eigen::Vector3d p = R * p_before + J * dxi;
    if (bend) p += (*bend)(p_before, dxi);
    landmark_means_.segment<3>(row) = p;
  }
}

void FilterState::deferPrediction(const Eigen::MatrixXd& gain, const Matrix6d& noise,
                                  const Eigen::VectorXd& random_walk, bool landmarks_follow_pose) {
  DeferredPredictions& d = deferred_;
  const int aux = layout_.auxDim();
  if (d.steps == 0) {
    d.landmarks_follow_pose = landmarks_follow_pose;
    d.gain_sum = Eigen::MatrixXd::Zero(StateLayout::kPoseDim, aux);
    d.noise_sum.setZero();
    d.random_walk_sum = Eigen::VectorXd::Zero(aux);
    d.walk_cross = Eigen::MatrixXd::Zero(StateLayout::kPoseDim, aux);
    d.walk_outer.setZero();
  } else if (d.landmarks_follow_pose != landmarks_follow_pose) {
    applyDeferredPredictions();
    deferPrediction(gain, noise, random_walk, landmarks_follow_pose);
    return;
  }
  // This step's F acts on the random walks of the earlier steps (H_k += G for each of them); its
  // own random walk comes after it.
  if (aux > 0) {
    const Eigen::MatrixXd gain_walk = gain * d.random_walk_sum.asDiagonal();
    d.walk_outer += d.walk_cross * gain.transpose() + gain * d.walk_cross.transpose() +
                    gain_walk * gain.transpose();
    d.walk_cross += gain_walk;
    d.gain_sum += gain;
    d.random_walk_sum += random_walk;
  }
  d.noise_sum += noise;
  noise_since_update_ += noise;
  ++d.steps;
}

void FilterState::addPoseProcessNoise(const Matrix6d& noise, bool landmarks_follow_pose) {
  // A step with F = I: only D noise D^T.
  deferPrediction(Eigen::MatrixXd::Zero(StateLayout::kPoseDim, layout_.auxDim()), noise,
                  Eigen::VectorXd::Zero(layout_.auxDim()), landmarks_follow_pose);
}

Eigen::MatrixXd FilterState::deferredNoiseMap() const {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(dim_, StateLayout::kPoseDim);
  D.topLeftCorner<6, 6>().setIdentity();
  if (deferred_.landmarks_follow_pose) {
    for (int row = layout_.headDim(); row < dim_; row += 3) {
      D.block<3, 3>(row, 3) = se3::hat(Eigen::Vector3d(landmark_means_.segment<3>(row)));
    }
  }
  return D;
}

void FilterState::applyDeferredPredictions() const {
  if (deferred_.steps == 0) return;
  const DeferredPredictions& d = deferred_;
  constexpr int kPoseDim = StateLayout::kPoseDim;
  const int aux = layout_.auxDim();
  const Eigen::MatrixXd D = deferredNoiseMap();
  const Matrix6d noise = d.noise_sum + d.walk_outer;
  Eigen::MatrixXd E, walk;
  if (aux > 0) {
    E = D * d.gain_sum;
    walk = D * d.walk_cross;
  }
  for (int which = 0; which < carriedCount(); ++which) {
    auto S = storage(which).topLeftCorner(dim_, dim_);
    if (aux > 0) {
      const Eigen::MatrixXd E_sigma = E * S.middleRows(kPoseDim, aux);  // dim x dim
      const Eigen::MatrixXd sigma_aa = S.block(kPoseDim, kPoseDim, aux, aux);
      S += E_sigma + E_sigma.transpose() + E * sigma_aa * E.transpose();
    }
    if (which >= covarianceCount()) continue;  // a track-noise part: F only
    S.noalias() += D * noise * D.transpose();
    if (aux > 0) {
      S.block(kPoseDim, kPoseDim, aux, aux).diagonal() += d.random_walk_sum;
      S.middleCols(kPoseDim, aux) += walk;
      S.middleRows(kPoseDim, aux) += walk.transpose();
    }
  }
  deferred_.steps = 0;
}

Matrix6d FilterState::poseCovariance(int which) const {
  const auto S = storage(which).topLeftCorner(dim_, dim_);
  Matrix6d pose = S.topLeftCorner<6, 6>();
  const DeferredPredictions& d = deferred_;
  if (d.steps == 0) return pose;
  // The pose rows of D are the identity: those of F S F^T + D Q D^T without the rest.
  const int aux = layout_.auxDim();
  if (aux > 0) {
    const Eigen::MatrixXd G_sigma = d.gain_sum * S.block(StateLayout::kPoseDim, 0, aux, 6);
    pose += G_sigma + G_sigma.transpose() +
            d.gain_sum * S.block(StateLayout::kPoseDim, StateLayout::kPoseDim, aux, aux) *
                d.gain_sum.transpose();
  }
  return pose + d.noise_sum + d.walk_outer;
}

Eigen::MatrixXd FilterState::auxCovariance(int which) const {
  const int aux = layout_.auxDim();
  Eigen::MatrixXd block =
      storage(which).block(StateLayout::kPoseDim, StateLayout::kPoseDim, aux, aux);
  // The auxiliary rows of D are zero: only the random walks reach this block.
  if (deferred_.steps > 0 && aux > 0) block.diagonal() += deferred_.random_walk_sum;
  return block;
}

void FilterState::setReportedVarianceAlong(int row, int dim, const Eigen::VectorXd& direction,
                                           double variance) {
  auto P = covariance(covarianceCount() - 1);
  const Eigen::MatrixXd block = P.block(row, row, dim, dim);
  const Eigen::LLT<Eigen::MatrixXd> llt(block);
  if (llt.info() != Eigen::Success || !std::isfinite(variance)) return;
  const double current = direction.dot(block * direction);
  // g = C S^-1 u; its own rows are u, so the block's variance along u becomes `variance`.
  const Eigen::VectorXd g = P.middleCols(row, dim) * llt.solve(direction);
  P.noalias() += (variance - current) * g * g.transpose();
}

void FilterState::propagateRoadTiltCovariance(double f, double variance) {
  const int row = layout_.tiltRow();
  for (int which = 0; which < carriedCount(); ++which) {
    auto S = storage(which).topLeftCorner(dim_, dim_);
    S.middleRows(row, 2) *= f;
    S.middleCols(row, 2) *= f;
    if (which < covarianceCount()) S.block<2, 2>(row, row).diagonal().array() += variance;
  }
}

void FilterState::foldTrackNoise(double factor) {
  if (!track_noise_carried_) return;
  auto P = covariance(1);
  P += (factor - 1.0) * covariance(kTrackNoise);
  track_noise_carried_ = false;
  track_noise_ = Eigen::MatrixXd();
}

}  // namespace ekf_vislam
