// Repeated frames under limits/repeated_frames: shift (doc/estimator.md, "Repeated frames"). A
// frame that repeats the previous one is not used as a measurement; its new tracks start there,
// the pose is cloned, and the tracks running through it are remembered. At the next frame those
// tracks are seen from the clone (StereoCandidate::via_clone); then their landmarks move by the
// clone-to-now motion, since from then on each such track reports its landmark carried along by
// the repeated frame's motion. No ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/feed_result.h"
#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/input_screening.h"
#include "ekf_vislam/core/landmark_manager.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/vislam_options.h"

#include <unordered_set>
#include <utility>
#include <vector>

namespace ekf_vislam {

class RepeatedFrameHandler {
 public:
  explicit RepeatedFrameHandler(const VislamOptions& options) : options_(&options) {}

  void clear() { crossing_ids_.clear(); }
  bool pending() const { return !crossing_ids_.empty(); }
  /// The track ran through the last repeated frame (its next observation is from the clone).
  bool crossesRepeatedFrame(uint32_t id) const { return crossing_ids_.count(id) > 0; }

  /// Holds a repeated frame: clones the pose, remembers its tracks, and starts the tracks that
  /// are new in it (new_tracks: indices into frame.features).
  void hold(const FeatureFrame& frame, const std::vector<size_t>& new_tracks,
            const InputScreening& screening, const StereoCamera& camera, FilterState* state,
            LandmarkManager* landmarks, EstimatorStats* stats, FeedResult* result);

  /// Moves each landmark of a track through the last repeated frame by the motion from the
  /// clone to now, p <- world_T_imu imu_T_world(clone) p, with its covariance through the exact
  /// Jacobian plus a depth uncertainty along the camera ray.
  void shiftCrossingTracks(const StereoCamera& camera, FilterState* state,
                           LandmarkManager* landmarks, EstimatorStats* stats, FeedResult* result);

 private:
  /// The covariance part of shiftCrossingTracks for one covariance: Sigma <- J Sigma J^T over
  /// the moved landmark rows (landmark row, R_D p^ of the old mean), plus the ray term when
  /// add_depth_noise.
  void shiftCovariance(const FilterState& state, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& p_camera_world,
                       const std::vector<std::pair<int, Eigen::Matrix3d>>& moved,
                       bool add_depth_noise, Eigen::Block<Eigen::MatrixXd> S) const;
  const VislamOptions* options_;               ///< not owned (the estimator keeps it alive)
  std::unordered_set<uint32_t> crossing_ids_;  ///< tracks through the last repeated frame
};

}  // namespace ekf_vislam
