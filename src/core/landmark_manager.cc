#include "ekf_vislam/core/landmark_manager.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/state_helper.h"

namespace ekf_vislam {

LandmarkManager::LandmarkManager(const VislamOptions& options)
    : options_(&options),
      observation_selector_(stereoObservationSelector(options.noise.merge_stereo_rows)) {}

void LandmarkManager::clear() {
  tracks_.clear();
  tracking_.clear();
  map_.clear();
  frame_ = 0;
  frame_stamp_ = 0.0;
}

std::optional<size_t> LandmarkManager::find(uint32_t id) const {
  auto it = tracking_.find(id);
  if (it == tracking_.end()) return std::nullopt;
  return it->second;
}

bool LandmarkManager::initialize(const StereoObservation& f, double stamp, size_t reuse_map_index,
                                 const StereoCamera& camera, FilterState* state,
                                 EstimatorStats* stats, FeedResult* result) {
  const int max_active = options_->landmarks.max_active;
  // Landmarks kept after their track ended (keep_all_in_state) do not count: that mode grows the
  // state on purpose.
  if (max_active > 0 && tracking_.size() >= static_cast<size_t>(max_active)) {
    stats->increment(Counter::kObsWaiting);  // not bad input: not counted as rejected
    return false;
  }
  const double v = options_->noise.merge_stereo_rows ? 0.5 * (f.v_left + f.v_right) : f.v_left;
  Eigen::Vector3d p_cam;
  Eigen::Matrix3d J_uvu;
  // Measured uR = true uR - offset.
  if (!camera.triangulate(f.u_left, v, f.u_right + state->disparity_offset, &p_cam, &J_uvu)) {
    stats->increment(Counter::kObsDisparity);
    ++result->observations_rejected;
    return false;
  }
  if (p_cam.z() < options_->landmarks.min_depth || p_cam.z() > options_->landmarks.max_depth) {
    stats->increment(Counter::kObsDepth);
    ++result->observations_rejected;
    return false;
  }
  const Eigen::Matrix4d& imu_T_cam = camera.imuTCam();
  const Eigen::Vector3d p_imu =
      imu_T_cam.topLeftCorner<3, 3>() * p_cam + imu_T_cam.topRightCorner<3, 1>();
  const Eigen::Matrix3d R_world_imu = state->imu_T_world.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d p_world = R_world_imu * (p_imu - state->imu_T_world.topRightCorner<3, 1>());

  const double pixel_var = options_->noise.pixel_sigma * options_->noise.pixel_sigma;
  const Eigen::Matrix3d J_z = R_world_imu * imu_T_cam.topLeftCorner<3, 3>() * J_uvu;
  // Error of the new landmark as a function of the state error: in SLAM mode the invariant error
  // xi = p_true - exp(phi^) p_mean = rho + R dp_imu to first order (correlated through rho), and
  // the triangulation also depends on the calibration states. Only the pose and auxiliary
  // columns of A = d xi / d state can be non-zero.
  const StateLayout& layout = state->layout();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3, StateLayout::kPoseDim + layout.auxDim());
  if (options_->mode == EstimatorMode::kSlam) A.leftCols<3>().setIdentity();
  if (layout.disparity_dim > 0) {
    // Element-wise: GCC 12 reports a false -Warray-bounds on a vectorized 3-vector copy here.
    for (int i = 0; i < 3; ++i) A(i, layout.disparityRow()) = J_z(i, 2);
  }
  if (layout.scale_dim > 0) {
    // Every coordinate of the triangulated point scales with the baseline.
    const Eigen::Vector3d dp_dbeta =
        R_world_imu * imu_T_cam.topLeftCorner<3, 3>() * p_cam / (1.0 + state->baseline_scale_error);
    for (int i = 0; i < 3; ++i) A(i, layout.scaleRow()) = dp_dbeta(i);
  }
  const Eigen::Matrix3d sigma_pixels = pixel_var * J_z * J_z.transpose();
  state_helper::augment(state, p_world, A, sigma_pixels);

  const size_t k = tracks_.size();
  const bool reuse = reuse_map_index < map_.size();
  LandmarkEstimate& estimate = reuse ? map_[reuse_map_index] : map_.emplace_back();
  estimate.id = f.id;
  estimate.p_world = p_world;
  estimate.covariance = covariance(*state, k);
  estimate.observations = 1;
  estimate.active = true;
  estimate.first_stamp = estimate.last_stamp = stamp;
  LandmarkTrack track;
  track.map_index = reuse ? reuse_map_index : map_.size() - 1;
  track.anchor_stamp = stamp;
  tracks_.push_back(track);
  tracking_[f.id] = k;
  setFlowReference(k, f, camera, *state);
  recordUsed(k, f);
  stats->increment(Counter::kLandmarkInitialized);
  stats->increment(Counter::kObservationInitialized);
  ++result->landmarks_initialized;
  return true;
}

void LandmarkManager::recordUsed(size_t k, const StereoObservation& f) {
  tracks_[k].previous_z = Eigen::Vector4d(f.u_left, f.v_left, f.u_right, f.v_right);
  tracks_[k].previous_frame = frame_;
  tracks_[k].previous_stamp = frame_stamp_;
}

void LandmarkManager::setFlowReference(size_t k, const StereoObservation& f,
                                       const StereoCamera& camera, const FilterState& state) {
  LandmarkTrack& track = tracks_[k];
  Eigen::Vector4d z_pred;
  Matrix43d H_landmark;
  // Predicted with the track's drift at its age, as the updater predicts the next observation.
  const Eigen::Vector3d drift_angle = track.ageAt(frame_stamp_) * state.track_drift_rate_imu;
  track.has_flow_reference =
      camera.projectTurned(state.imu_T_world, state.landmark(k), drift_angle, &z_pred, &H_landmark,
                           nullptr, options_->landmarks.min_depth * 0.5);
  if (!track.has_flow_reference) return;
  // Rows uL and v of the observation (the first two of the selector in either layout).
  const Eigen::Matrix<double, 2, 4> M2 = observation_selector_.topRows<2>();
  const Eigen::Vector4d z(f.u_left, f.v_left, f.u_right, f.v_right);
  track.flow_residual = M2 * (z - z_pred);
  track.flow_H_landmark = M2 * H_landmark;
}

std::vector<bool> LandmarkManager::endedTracks(const std::unordered_set<uint32_t>& present,
                                               bool frame_empty) {
  std::vector<bool> ended(tracks_.size(), false);
  for (const auto& [id, k] : tracking_) {
    LandmarkTrack& track = tracks_[k];
    if (present.count(id)) {
      track.frames_absent = 0;
    } else if (!frame_empty) {
      track.has_flow_reference = false;  // its next observation is not one frame after the last
      if (++track.frames_absent > options_->landmarks.max_track_gap) ended[k] = true;
    }
  }
  return ended;
}

int LandmarkManager::endTracks(const std::vector<bool>& ended, FilterState* state,
                               EstimatorStats* stats) {
  if (options_->landmarks.keep_all_in_state) {
    for (size_t k = 0; k < tracks_.size(); ++k) {
      if (!ended[k]) continue;
      tracking_.erase(map_[tracks_[k].map_index].id);
      tracks_[k].tracking = false;
    }
    return 0;
  }
  const size_t before = tracks_.size();
  remove(ended, /*count_as_marginalized=*/true, state, stats);
  return static_cast<int>(before - tracks_.size());
}

void LandmarkManager::remove(const std::vector<bool>& flags, bool count_as_marginalized,
                             FilterState* state, EstimatorStats* stats) {
  // Only the leaving landmarks need their final estimate in the map now (the others are synced
  // at the end of the frame); last_stamp stays the last frame the track was seen in.
  std::vector<LandmarkTrack> kept;
  for (size_t k = 0; k < tracks_.size(); ++k) {
    if (!flags[k]) {
      kept.push_back(tracks_[k]);
      continue;
    }
    syncEntry(*state, k);
    LandmarkEstimate& l = map_[tracks_[k].map_index];
    l.active = false;
    tracking_.erase(l.id);
    if (count_as_marginalized) stats->increment(Counter::kLandmarkMarginalized);
  }
  state_helper::marginalizeLandmarks(state, flags);
  tracks_.swap(kept);
  tracking_.clear();
  for (size_t k = 0; k < tracks_.size(); ++k) {
    if (tracks_[k].tracking) tracking_[map_[tracks_[k].map_index].id] = k;
  }
}

void LandmarkManager::apply(const LandmarkDecisions& decisions, FilterState* state,
                            EstimatorStats* stats, FeedResult* result) {
  if (decisions.empty()) return;
  std::vector<bool> flags(tracks_.size(), false);
  for (const auto* list : {&decisions.restart, &decisions.split, &decisions.jumped}) {
    for (size_t k : *list) flags[k] = true;
  }
  remove(flags, /*count_as_marginalized=*/false, state, stats);
  const size_t ended = decisions.split.size() + decisions.jumped.size();
  stats->increment(Counter::kLandmarkReinitialized, decisions.restart.size());
  stats->increment(Counter::kLandmarkSplit, decisions.split.size());
  stats->increment(Counter::kLandmarkJump, decisions.jumped.size());
  stats->increment(Counter::kLandmarkMarginalized, ended);
  result->landmarks_marginalized += static_cast<int>(ended);
}

Eigen::Matrix3d LandmarkManager::covariance(const FilterState& state, size_t k) const {
  // The world error dp of the landmark from the joint covariance of [rho; phi; xi]. SLAM: its
  // state carries the pose's rho, dp = xi - p^ phi. Mapping: it was placed from the dead-reckoned
  // poses as if they were exact (xi is that placement's error), and a pose error exp([rho; phi]^)
  // moves it by rho - p^ phi (the pose covariance of now: its latest frame's once it has left).
  const int row = state.layout().landmarkRow(k);
  const auto S = state.reportedCovariance();
  Eigen::Matrix<double, 3, 9> M;
  if (options_->mode == EstimatorMode::kSlam) {
    M.leftCols<3>().setZero();
  } else {
    M.leftCols<3>().setIdentity();
  }
  M.middleCols<3>(3) = -se3::hat(state.landmark(k));
  M.rightCols<3>().setIdentity();
  Eigen::Matrix<double, 9, 9> joint;
  joint.topLeftCorner<6, 6>() = S.block<6, 6>(StateLayout::kPoseRow, StateLayout::kPoseRow);
  joint.topRightCorner<6, 3>() = S.block<6, 3>(StateLayout::kPoseRow, row);
  joint.bottomLeftCorner<3, 6>() = S.block<3, 6>(row, StateLayout::kPoseRow);
  joint.bottomRightCorner<3, 3>() = S.block<3, 3>(row, row);
  return M * joint * M.transpose();
}

void LandmarkManager::syncEntry(const FilterState& state, size_t k) {
  LandmarkEstimate& l = map_[tracks_[k].map_index];
  l.p_world = state.landmark(k);
  l.covariance = covariance(state, k);
}

void LandmarkManager::syncMap(const FilterState& state, double time) {
  for (size_t k = 0; k < tracks_.size(); ++k) {
    syncEntry(state, k);
    LandmarkEstimate& l = map_[tracks_[k].map_index];
    l.active = true;
    if (tracks_[k].tracking && tracks_[k].frames_absent == 0) l.last_stamp = time;
  }
}

}  // namespace ekf_vislam
