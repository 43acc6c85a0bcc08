#include "ekf_vislam/core/stereo_updater.h"

#include "ekf_vislam/core/chi_square.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/track_jump_detector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ekf_vislam {

namespace {
/// Residual pairs before the track correlation is used (a frame of the KITTI tracks has ~100).
constexpr int kTrackCorrelationMinPairs = 100;
}  // namespace

StereoUpdater::StereoUpdater(const VislamOptions& options)
    : options_(&options),
      rows_per_observation_(options.noise.merge_stereo_rows ? 3 : 4),
      observation_selector_(stereoObservationSelector(options.noise.merge_stereo_rows)),
      gate_threshold_(
          chiSquareQuantile(options.landmarks.gating_probability, rows_per_observation_)),
      restart_threshold_(chiSquareQuantile(0.9999, rows_per_observation_)),
      track_correlation_(options.noise.track_correlation_window, kTrackCorrelationMinPairs,
                         options.noise.track_correlation_max) {
  prediction_check_.gate_threshold = gate_threshold_;
  prediction_check_.likelihood_cap = restart_threshold_;
}

bool StereoUpdater::predict(const StereoCamera& camera, const FilterState& state,
                            const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
                            const Eigen::Vector4d& z, double age, Eigen::VectorXd* residual,
                            Eigen::MatrixXd* H_landmark, Eigen::MatrixXd* H_calibration,
                            Eigen::MatrixXd* H_drift) const {
  const StateLayout& layout = state.layout();
  const Eigen::MatrixXd& M = observation_selector_;
  // Track drift: the track shows the point turned by exp(age w^) about the IMU origin.
  Eigen::Vector4d z_pred;
  Matrix43d H, H_angle = Matrix43d::Zero();
  const bool jacobians = H_landmark != nullptr;
  const bool drift = jacobians && layout.drift_dim > 0;
  if (!camera.projectTurned(imu_T_world, p_world, age * state.track_drift_rate_imu, &z_pred,
                            jacobians ? &H : nullptr, drift ? &H_angle : nullptr,
                            options_->landmarks.min_depth * 0.5)) {
    return false;
  }
  if (jacobians) {
    *H_drift = age * M * H_angle.leftCols(layout.drift_dim);
    // d z / d calibration: the uR row only. Offset: measured uR = true uR - offset. Baseline
    // scale: uR = fx (x - b0 (1 + beta)) / z + cx, d uR / d beta = -fx b0 / z.
    Eigen::Matrix<double, 4, 2> H_cal = Eigen::Matrix<double, 4, 2>::Zero();
    if (layout.disparity_dim > 0) H_cal(2, 0) = -1.0;
    if (layout.scale_dim > 0) {
      H_cal(2, layout.disparity_dim) =
          -(z_pred(0) - z_pred(2)) / (1.0 + state.baseline_scale_error);
    }
    *H_calibration = M * H_cal.leftCols(layout.calibrationDim());
    *H_landmark = M * H;
  }
  z_pred(2) -= state.disparity_offset;
  *residual = M * (z - z_pred);
  return true;
}

void StereoUpdater::setCloneView(const Eigen::Vector3d& p_world, double weight, StereoCandidate* c,
                                 const Eigen::MatrixXd& H_landmark_clone) {
  // Seen from the clone (error [rho_c; phi_c]): p_imu = R_c^T (p_mean + xi - rho_c +
  // p^ (phi_c - phi) - t_c) to first order, so the current pose enters through phi only.
  // `weight` scales this view's part (1: seen from the clone; -rho: the previous observation's
  // prediction subtracted from the current one).
  const Eigen::MatrixXd H_p = H_landmark_clone * se3::hat(p_world);
  c->H_pose.rightCols<3>() -= weight * H_p;
  c->H_clone = Eigen::MatrixXd::Zero(H_p.rows(), StateLayout::kPoseDim);
  c->H_clone.leftCols<3>() = -weight * H_landmark_clone;
  c->H_clone.rightCols<3>() = weight * H_p;
  c->clone_columns = true;
}

bool StereoUpdater::linearize(const StereoCamera& camera, const FilterState& state,
                              StereoCandidate* c) const {
  const StateLayout& layout = state.layout();
  const Eigen::Vector3d p_world = state.landmark(c->landmark);
  const Eigen::Vector4d z(c->feature.u_left, c->feature.v_left, c->feature.u_right,
                          c->feature.v_right);
  const Eigen::Matrix4d& imu_T_world = c->via_clone ? state.imu_T_world_clone : state.imu_T_world;
  if (!predict(camera, state, imu_T_world, p_world, z, c->track_age, &c->residual, &c->H_landmark,
               &c->H_calibration, &c->H_drift)) {
    return false;
  }
  // Invariant error: p_imu = R^T (p_mean + xi - rho - p) to first order, so the observation
  // depends on rho through -H_landmark and not at all on phi.
  c->H_pose = Eigen::MatrixXd::Zero(rows_per_observation_, StateLayout::kPoseDim);
  c->clone_columns = false;
  if (c->via_clone && layout.clone_dim > 0) {
    setCloneView(p_world, 1.0, c, c->H_landmark);
  } else if (options_->mode == EstimatorMode::kSlam) {
    c->H_pose.leftCols<3>() = -c->H_landmark;
  }
  return true;
}

bool StereoUpdater::linearizeCandidate(const StereoCamera& camera, const FilterState& state,
                                       const LandmarkManager& landmarks, StereoCandidate* c) const {
  const LandmarkTrack& track = landmarks.track(c->landmark);
  c->track_age = track.ageAt(landmarks.frameStamp());
  if (!linearize(camera, state, c)) return false;
  // The track-jump test compares the observation itself with the last frame's.
  c->flow_residual = c->residual.head<2>();
  c->flow_H_landmark = c->H_landmark.topRows<2>();
  difference(camera, state, landmarks, c);
  gate(state, c);
  return true;
}

void StereoUpdater::gate(const FilterState& state, StereoCandidate* c) const {
  const double pixel_var = options_->noise.pixel_sigma * options_->noise.pixel_sigma;
  c->innovation_cov = state_helper::innovationCovariance(state, gateJacobian(state, *c), pixel_var);
  c->mahalanobis2 = c->residual.dot(c->innovation_cov.ldlt().solve(c->residual));
}

void StereoUpdater::checkPrediction(std::vector<StereoCandidate>* candidates, FilterState* state,
                                    EstimatorStats* stats, FeedResult* result) const {
  // An observation seen from the clone (a track through a repeated frame) shows its landmark
  // from the pose at that frame: what the prediction added since does not reach it, so it can
  // neither disagree with the prediction nor vote on it.
  const auto sees_the_prediction = [](const StereoCandidate& c) {
    return c.predicted && !c.via_clone;
  };
  int predicted = 0, gated = 0;
  for (const StereoCandidate& c : *candidates) {
    if (!sees_the_prediction(c)) continue;
    ++predicted;
    if (!(c.mahalanobis2 <= gate_threshold_)) ++gated;
  }
  if (!predictionSuspected(gated, predicted, prediction_check_)) return;
  // The process noise reaches an observation through the pose's columns and, the landmark error
  // being attached to the current rotation, through the landmark's: D = [0, p^] there.
  std::vector<PredictionCheckInput> inputs;
  inputs.reserve(static_cast<size_t>(predicted));
  for (const StereoCandidate& c : *candidates) {
    if (!sees_the_prediction(c)) continue;
    Eigen::MatrixXd B = c.H_pose;
    B.rightCols<3>() += c.H_landmark * se3::hat(state->landmark(c.landmark));
    inputs.push_back({c.residual, c.innovation_cov, B});
  }
  const Matrix6d process_noise = state->processNoiseSinceUpdate();
  const PredictionVerdict verdict = judgePrediction(inputs, process_noise, prediction_check_);
  if (!verdict.joint) return;
  stats->increment(Counter::kFrameGatedJointly);
  if (verdict.factor > 1.0) {
    state->addPoseProcessNoise((verdict.factor - 1.0) * process_noise, true);
    stats->increment(Counter::kFramePredictionWidened);
  }
  // Gated jointly: each on what the pose change the frame shares leaves of it. The others (seen
  // from the clone) are gated again against the widened covariance.
  size_t i = 0;
  for (StereoCandidate& c : *candidates) {
    if (sees_the_prediction(c)) {
      c.mahalanobis2 = verdict.joint_d2[i++];
    } else if (c.predicted && verdict.factor > 1.0) {
      gate(*state, &c);
    }
  }
  if (verdict.factor > 1.0 && result->message.empty()) {
    std::ostringstream why;
    why << gated << " of " << predicted
        << " re-observed landmarks disagreed with the prediction: the process noise since the "
           "last update taken x"
        << verdict.factor << " (a twist worse than its noise model)";
    result->message = why.str();
  }
}

void StereoUpdater::difference(const StereoCamera& camera, const FilterState& state,
                               const LandmarkManager& landmarks, StereoCandidate* c) const {
  // The pixel error e_k of a track follows e_k = rho e_(k-1) + w_k (AR(1), stationary std
  // pixel_sigma). The differenced observation z_k - rho z_(k-1) = h(pose_k, p) -
  // rho h(pose_(k-1), p) + w_k has white noise of variance pixel_sigma^2 (1 - rho^2)
  // (Bryson and Henrikson); pose_(k-1) is the clone, taken at the end of every frame. The
  // residual and Jacobians are whitened by 1 / sqrt(1 - rho^2) so the update keeps one
  // variance, pixel_sigma^2.
  const double rho = options_->noise.pixel_correlation;
  const LandmarkTrack& track = landmarks.track(c->landmark);
  c->differenced = false;
  if (rho <= 0.0 || c->via_clone || track.previous_frame != landmarks.frame() - 1) return;
  const Eigen::Vector3d p_world = state.landmark(c->landmark);
  Eigen::VectorXd residual_prev;
  Eigen::MatrixXd H_landmark_prev, H_calibration_prev, H_drift_prev;
  const double age_prev = track.ageAt(track.previous_stamp);
  if (!predict(camera, state, state.imu_T_world_clone, p_world, track.previous_z, age_prev,
               &residual_prev, &H_landmark_prev, &H_calibration_prev, &H_drift_prev)) {
    return;
  }
  const double whiten = 1.0 / std::sqrt(1.0 - rho * rho);
  c->residual = whiten * (c->residual - rho * residual_prev);
  c->H_calibration = whiten * (c->H_calibration - rho * H_calibration_prev);
  c->H_drift = whiten * (c->H_drift - rho * H_drift_prev);
  if (options_->mode == EstimatorMode::kSlam && state.layout().clone_dim > 0) {
    setCloneView(p_world, -rho, c, H_landmark_prev);
    c->H_pose *= whiten;
    c->H_clone *= whiten;
  }
  c->H_landmark = whiten * (c->H_landmark - rho * H_landmark_prev);
  c->differenced = true;
}

SparseJacobian StereoUpdater::gateJacobian(const FilterState& state,
                                           const StereoCandidate& c) const {
  const StateLayout& layout = state.layout();
  SparseJacobian jacobian{{StateLayout::kPoseRow, c.H_pose}};
  if (layout.calibrationDim() > 0) jacobian.push_back({layout.calibrationRow(), c.H_calibration});
  if (layout.drift_dim > 0) jacobian.push_back({layout.driftRow(), c.H_drift});
  if (c.clone_columns) jacobian.push_back({layout.cloneRow(), c.H_clone});
  jacobian.push_back({layout.landmarkRow(c.landmark), c.H_landmark});
  return jacobian;
}

SparseJacobian StereoUpdater::updateJacobian(const FilterState& state,
                                             const StereoCandidate& c) const {
  const StateLayout& layout = state.layout();
  SparseJacobian jacobian{{layout.landmarkRow(c.landmark), c.H_landmark}};
  if (options_->mode == EstimatorMode::kSlam) jacobian.push_back({StateLayout::kPoseRow, c.H_pose});
  if (c.clone_columns) jacobian.push_back({layout.cloneRow(), c.H_clone});
  if (layout.calibrationDim() > 0) jacobian.push_back({layout.calibrationRow(), c.H_calibration});
  if (layout.drift_dim > 0) jacobian.push_back({layout.driftRow(), c.H_drift});
  return jacobian;
}

StereoUpdateOutcome StereoUpdater::update(std::vector<StereoCandidate>* candidates, bool jump_test,
                                          const StereoCalibration& nominal, StereoCamera* camera,
                                          FilterState* state, LandmarkManager* landmarks,
                                          EstimatorStats* stats, FeedResult* result) {
  StereoUpdateOutcome outcome;
  for (StereoCandidate& c : *candidates) {
    c.predicted = linearizeCandidate(*camera, *state, *landmarks, &c);
    if (!c.predicted) {
      stats->increment(Counter::kObsBehindCamera);
      ++result->observations_rejected;
      landmarks->track(c.landmark).has_flow_reference = false;
    }
  }
  if (options_->landmarks.prediction_check && options_->mode == EstimatorMode::kSlam) {
    checkPrediction(candidates, state, stats, result);
  }
  state->markUpdate();
  if (jump_test) detectJumps(*state, *landmarks, candidates);
  std::vector<StereoCandidate*> accepted;
  accepted.reserve(candidates->size());
  for (StereoCandidate& c : *candidates) {
    if (c.predicted && decide(&c, landmarks, &outcome, stats, result)) accepted.push_back(&c);
  }
  if (!accepted.empty() && stackedUpdate(accepted, state, &outcome, landmarks, stats, result)) {
    if (state->layout().scale_dim > 0) {
      *camera = scaledStereoCamera(nominal, state->baseline_scale_error);
    }
    if (state->covarianceCount() > 1) {
      recordPosteriorResiduals(*camera, *state, accepted, landmarks);
      // Until the correlation has an estimate the frames' tracks are counted as white; once it
      // has one, they are counted at it, as the later frames are at theirs.
      if (state->carriesTrackNoise() && track_correlation_.ready()) {
        track_noise_recount_factor_ = track_correlation_.varianceFactor();
        state->foldTrackNoise(track_noise_recount_factor_);
      }
    }
  }
  for (const StereoCandidate* c : accepted) {
    landmarks->setFlowReference(c->landmark, c->feature, *camera, *state);
    landmarks->recordUsed(c->landmark, c->feature);
  }
  return outcome;
}

bool StereoUpdater::decide(StereoCandidate* c, LandmarkManager* landmarks,
                           StereoUpdateOutcome* outcome, EstimatorStats* stats,
                           FeedResult* result) const {
  LandmarkTrack& track = landmarks->track(c->landmark);
  if (c->jumped) {
    ++outcome->disagreeing;
    if (!track.jump_suspected) {
      // A gross outlier in one frame, or the track slid onto another point: the observation is
      // not used and the landmark waits for the next one, tested against the same flow
      // reference (the last one used).
      track.jump_suspected = true;
      stats->increment(Counter::kObsJumpHeld);
      ++result->observations_rejected;
      return false;
    }
    // Twice in a row: the track slid onto another point. The landmark leaves the state (its
    // estimate stays in the map) and the track goes on as a new landmark from its next
    // observation.
    outcome->leaving.jumped.push_back(c->landmark);
    return false;
  }
  track.jump_suspected = false;
  const double d2 = c->mahalanobis2;
  if (!(d2 <= gate_threshold_)) {
    stats->increment(Counter::kObsGated);
    ++result->observations_rejected;
    ++outcome->disagreeing;
    // A landmark known from one observation may have been started by an outlier, and a track
    // that keeps failing the gate has jumped (seen in the KITTI tracks): restart either from
    // its current observation instead of gating the rest of its track away.
    track.has_flow_reference = false;
    // Only gross disagreement counts towards a restart: chance gatings of a good track (5 % at
    // a 95 % gate) must not throw its accumulated information away.
    if (d2 > restart_threshold_) ++track.consecutive_gated;
    const bool restart = landmarks->mapEntry(c->landmark).observations <= 1 ||
                         (options_->landmarks.reinitialize_after_gated > 0 &&
                          track.consecutive_gated >= options_->landmarks.reinitialize_after_gated);
    if (restart) {
      outcome->leaving.restart.push_back(c->landmark);
      outcome->restart_from.push_back(*c);
      outcome->restart_from.back().reuse_map_index = track.map_index;
    }
    return false;
  }
  track.consecutive_gated = 0;
  if (options_->landmarks.max_track_length > 0 &&
      track.frames > options_->landmarks.max_track_length) {
    // Long track (real tracks drift off their point): the landmark leaves the state and the
    // track goes on as a new landmark (new map entry) from this observation, which has just
    // passed the gate, so an outlier never starts the new segment.
    outcome->leaving.split.push_back(c->landmark);
    outcome->restart_from.push_back(*c);
    return false;
  }
  return true;
}

bool StereoUpdater::stackedUpdate(const std::vector<StereoCandidate*>& accepted, FilterState* state,
                                  StereoUpdateOutcome* outcome, LandmarkManager* landmarks,
                                  EstimatorStats* stats, FeedResult* result) const {
  const int r = rows_per_observation_;
  const int n = static_cast<int>(accepted.size());
  std::vector<SparseJacobian> jacobians;
  jacobians.reserve(n);
  Eigen::VectorXd residual(r * n);
  for (int k = 0; k < n; ++k) {
    jacobians.push_back(updateJacobian(*state, *accepted[k]));
    residual.segment(static_cast<Eigen::Index>(k) * r, r) = accepted[k]->residual;
  }
  const double pixel_var = options_->noise.pixel_sigma * options_->noise.pixel_sigma;
  const ConsiderRows consider_rows = {
      countsSpeedScale(*options_) ? state->layout().speedScaleRow() : -1,
      countsDisparityOffset(*options_) ? state->layout().disparityRow() : -1};
  const UpdateOutcome update = state_helper::update(
      state, jacobians, residual, pixel_var, options_->mode == EstimatorMode::kSlam,
      pixel_var * track_correlation_.varianceFactor(), consider_rows, true);
  if (update.status == UpdateStatus::kNotPositiveDefinite) {
    stats->increment(Counter::kUpdateNonFinite);
    result->message = "innovation covariance not positive definite: update skipped";
    return false;
  }
  if (update.status == UpdateStatus::kNonFinite) {
    stats->increment(Counter::kUpdateNonFinite);
    result->message = "update produced non-finite numbers: discarded";
    return false;
  }
  outcome->speed_scale = update.consider[0];
  outcome->disparity_offset = update.consider[1];
  for (const StereoCandidate* c : accepted) ++landmarks->mapEntry(c->landmark).observations;
  stats->increment(Counter::kObservationUpdate, n);
  result->observations_updated += n;
  if (update.covariance_repaired) stats->increment(Counter::kCovarianceRepaired);
  return true;
}

void StereoUpdater::recordPosteriorResiduals(const StereoCamera& camera, const FilterState& state,
                                             const std::vector<StereoCandidate*>& accepted,
                                             LandmarkManager* landmarks) {
  Eigen::VectorXd residual;
  for (const StereoCandidate* c : accepted) {
    const Eigen::Vector4d z(c->feature.u_left, c->feature.v_left, c->feature.u_right,
                            c->feature.v_right);
    const Eigen::Matrix4d& imu_T_world = c->via_clone ? state.imu_T_world_clone : state.imu_T_world;
    if (!predict(camera, state, imu_T_world, state.landmark(c->landmark), z, c->track_age,
                 &residual)) {
      continue;
    }
    LandmarkTrack& track = landmarks->track(c->landmark);
    if (track.posterior_frame == landmarks->frame() - 1) {
      track_correlation_.add(residual, track.posterior_residual);
    }
    track.posterior_residual = residual;
    track.posterior_frame = landmarks->frame();
  }
}

void StereoUpdater::detectJumps(const FilterState& state, const LandmarkManager& landmarks,
                                std::vector<StereoCandidate>* candidates) const {
  if (options_->landmarks.jump_threshold_px <= 0.0) return;
  const auto S = state.covariance();
  std::vector<FlowCheck> checks;
  std::vector<StereoCandidate*> checked;
  checks.reserve(candidates->size());
  checked.reserve(candidates->size());
  for (StereoCandidate& c : *candidates) {
    const LandmarkTrack& track = landmarks.track(c.landmark);
    if (!c.predicted || !track.has_flow_reference) continue;
    const int row = state.layout().landmarkRow(c.landmark);
    FlowCheck check;
    check.residual_change = c.flow_residual - track.flow_residual;
    // Pose error exp(eps^) world_T_imu with the landmark fixed: d p_world = -rho - phi x p.
    const Eigen::Matrix<double, 2, 3>& H = c.flow_H_landmark;
    check.H_pose.leftCols<3>() = -H;
    check.H_pose.rightCols<3>() = H * se3::hat(state.landmark(c.landmark));
    // The landmark's own error moves both predictions: (H_now - H_before) Sigma_l (...)^T.
    const Eigen::Matrix<double, 2, 3> D = H - track.flow_H_landmark;
    check.landmark_variance = (D * S.block<3, 3>(row, row) * D.transpose()).diagonal();
    checks.push_back(check);
    checked.push_back(&c);
  }
  TrackJumpOptions jump_options;
  jump_options.threshold_px = options_->landmarks.jump_threshold_px;
  jump_options.threshold_sigmas = options_->landmarks.jump_threshold_sigmas;
  const TrackJumpResult jumps = detectTrackJumps(checks, jump_options);
  for (size_t i = 0; i < checked.size(); ++i) checked[i]->jumped = jumps.jumped[i];
}

}  // namespace ekf_vislam
