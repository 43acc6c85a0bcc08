// The stereo update: for each re-observed landmark the predicted observation
// z = Ks pi(cam_T_imu T^-1 m), its residual and Jacobians, a verdict (gated, restarted, split,
// jumped, accepted), then one stacked EKF update with the accepted ones. No ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/feed_result.h"
#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/landmark_manager.h"
#include "ekf_vislam/core/prediction_check.h"
#include "ekf_vislam/core/state_helper.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/track_correlation_estimator.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <vector>

namespace ekf_vislam {

/// One observation of a landmark in the state (or, for initialization, of a new track).
struct StereoCandidate {
  StereoObservation feature;
  size_t landmark = 0;  ///< state index (update candidates)
  /// A restart: overwrite this map entry instead of adding one.
  size_t reuse_map_index = LandmarkManager::kNewMapEntry;
  /// The track ran through the last repeated frame: this observation shows its landmark from the
  /// clone (the pose at that frame), not from the current pose.
  bool via_clone = false;
  // Filled by the updater.
  double track_age = 0.0;  ///< s since the landmark started (track_drift/)
  Eigen::VectorXd residual;
  Eigen::MatrixXd H_pose;         ///< rows x 6
  Eigen::MatrixXd H_landmark;     ///< rows x 3
  Eigen::MatrixXd H_calibration;  ///< rows x calibration dim
  Eigen::MatrixXd H_drift;        ///< rows x 3, when the track drift rate is in the state
  Eigen::MatrixXd H_clone;        ///< rows x 6, when seen from the clone in SLAM mode
  bool clone_columns = false;     ///< H_clone is used
  /// Differenced with the track's previous observation (noise/pixel_correlation): residual and
  /// Jacobians are those of the whitened z_k - rho z_(k-1).
  bool differenced = false;
  /// Rows [uL, v] of the observation's own residual and landmark Jacobian (before any
  /// differencing): the track-jump test's input.
  Eigen::Vector2d flow_residual = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 2, 3> flow_H_landmark = Eigen::Matrix<double, 2, 3>::Zero();
  Eigen::MatrixXd innovation_cov;  ///< H Sigma H^T + R of the gate (the gains' covariance)
  double mahalanobis2 = 0.0;       ///< of the residual against its own innovation covariance
  bool predicted = false;          ///< false: the landmark is not in front of the camera
  bool jumped = false;             ///< the track-jump test flagged it
};

/// What the update decided besides the correction.
struct StereoUpdateOutcome {
  LandmarkDecisions leaving;  ///< landmarks that leave the state (apply at once)
  /// Observations that start a landmark again (restarts and splits), in candidate order.
  std::vector<StereoCandidate> restart_from;
  /// Observations that disagreed with the filter (gated or jumped).
  int disagreeing = 0;
  /// What the update's innovations say of the counted speed scale and disparity offset
  /// (UpdateOutcome::consider; 0 for one not counted).
  ConsiderEvidence speed_scale;
  ConsiderEvidence disparity_offset;
};

class StereoUpdater {
 public:
  explicit StereoUpdater(const VislamOptions& options);

  int rowsPerObservation() const { return rows_per_observation_; }

  /// Residual, Jacobian blocks (differenced with the track's previous observation when
  /// noise/pixel_correlation applies) and Mahalanobis distance of one candidate; false when the
  /// landmark is not in front of the camera.
  bool linearizeCandidate(const StereoCamera& camera, const FilterState& state,
                          const LandmarkManager& landmarks, StereoCandidate* c) const;

  /// Linearizes every candidate, runs the track-jump test (when jump_test), decides each one and
  /// updates the state with the accepted observations. Landmark bookkeeping (gating counts,
  /// flow references, observation counts) follows; removals are returned, not applied. With
  /// the baseline scale in the state, *camera follows its corrected estimate (from `nominal`).
  StereoUpdateOutcome update(std::vector<StereoCandidate>* candidates, bool jump_test,
                             const StereoCalibration& nominal, StereoCamera* camera,
                             FilterState* state, LandmarkManager* landmarks, EstimatorStats* stats,
                             FeedResult* result);

  /// The online estimate of the tracks' frame-to-frame residual correlation.
  const TrackCorrelationEstimator& trackCorrelation() const { return track_correlation_; }
  /// The variance factor the frames before the track correlation's first estimate were
  /// recounted with once it came (FilterState::foldTrackNoise); 0 until then.
  double trackNoiseRecountFactor() const { return track_noise_recount_factor_; }
  /// Forgets what was learned from earlier updates (the track correlation).
  void reset() {
    track_correlation_.reset();
    track_noise_recount_factor_ = 0.0;
  }

 private:
  /// Residual and Jacobians (landmark, calibration, track drift rate) of observation z, of age
  /// `age` (s), of p_world from a pose; false when the point is not in front of the camera.
  /// Without H_landmark (nullptr), the residual only.
  bool predict(const StereoCamera& camera, const FilterState& state,
               const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
               const Eigen::Vector4d& z, double age, Eigen::VectorXd* residual,
               Eigen::MatrixXd* H_landmark = nullptr, Eigen::MatrixXd* H_calibration = nullptr,
               Eigen::MatrixXd* H_drift = nullptr) const;
  /// Adds `weight` times the pose and clone Jacobians of a view from the clone.
  static void setCloneView(const Eigen::Vector3d& p_world, double weight, StereoCandidate* c,
                           const Eigen::MatrixXd& H_landmark_clone);
  /// Predicted observation, residual and Jacobians of one candidate; false when the landmark is
  /// not in front of the camera.
  bool linearize(const StereoCamera& camera, const FilterState& state, StereoCandidate* c) const;
  /// With noise/pixel_correlation, turns a candidate whose previous observation came in the
  /// last frame into the whitened difference with it (see the .cc).
  void difference(const StereoCamera& camera, const FilterState& state,
                  const LandmarkManager& landmarks, StereoCandidate* c) const;
  /// Jacobian blocks over the touched variables: for the gate, and for the stacked update.
  SparseJacobian gateJacobian(const FilterState& state, const StereoCandidate& c) const;
  SparseJacobian updateJacobian(const FilterState& state, const StereoCandidate& c) const;
  /// Gate of one linearized candidate against the state's covariance (innovation covariance
  /// and Mahalanobis distance).
  void gate(const FilterState& state, StereoCandidate* c) const;
  /// landmarks/prediction_check: when most candidates fail the gate, widens the pose's process
  /// noise since the last update as the frame prefers and gates the frame jointly
  /// (prediction_check.h).
  void checkPrediction(std::vector<StereoCandidate>* candidates, FilterState* state,
                       EstimatorStats* stats, FeedResult* result) const;
  /// Flags the candidates whose track jumped (track_jump_detector.h).
  void detectJumps(const FilterState& state, const LandmarkManager& landmarks,
                   std::vector<StereoCandidate>* candidates) const;
  /// Gate, restart and split policy for one linearized candidate: true when it is accepted.
  bool decide(StereoCandidate* c, LandmarkManager* landmarks, StereoUpdateOutcome* outcome,
              EstimatorStats* stats, FeedResult* result) const;
  /// Feeds the accepted observations' residuals after the update to the track-correlation
  /// estimate (noise/report_track_correlation).
  void recordPosteriorResiduals(const StereoCamera& camera, const FilterState& state,
                                const std::vector<StereoCandidate*>& accepted,
                                LandmarkManager* landmarks);
  /// True when the state was corrected.
  bool stackedUpdate(const std::vector<StereoCandidate*>& accepted, FilterState* state,
                     StereoUpdateOutcome* outcome, LandmarkManager* landmarks,
                     EstimatorStats* stats, FeedResult* result) const;

  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
  int rows_per_observation_ = 3;
  Eigen::MatrixXd observation_selector_;  ///< rows x 4
  double gate_threshold_ = 0.0;
  double restart_threshold_ = 0.0;  ///< chi-square 0.9999: gross disagreement (track jumped)
  PredictionCheckOptions prediction_check_;  ///< the gate's thresholds, built once
  TrackCorrelationEstimator track_correlation_;
  double track_noise_recount_factor_ = 0.0;
};

}  // namespace ekf_vislam
