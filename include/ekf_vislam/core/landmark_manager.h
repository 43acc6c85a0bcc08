// The landmarks of the filter: track id to state variable, initialization from one stereo
// observation, the per-track bookkeeping (gap, gating, flow reference), removal from the state
// and the map of every landmark ever initialized. No ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/feed_result.h"
#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace ekf_vislam {

/// Bookkeeping of one landmark in the state (index k: state rows StateLayout::landmarkRow(k)).
struct LandmarkTrack {
  size_t map_index = 0;
  bool tracking = true;       ///< false: its track ended but it stays (keep_all_landmarks_in_state)
  int consecutive_gated = 0;  ///< frames in a row whose observation disagreed grossly
  int frames = 1;             ///< frames its track has been seen in since this landmark started
  int frames_absent = 0;      ///< consecutive non-empty frames its id was missing from
  /// Residual [uL, v] (px) left after the last update that used it: the reference of the next
  /// frame's track-jump test. Valid only when has_flow_reference.
  Eigen::Vector2d flow_residual = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 2, 3> flow_H_landmark = Eigen::Matrix<double, 2, 3>::Zero();
  bool has_flow_reference = false;
  /// The last observation failed the track-jump test and was not used: a second failure in a
  /// row ends the landmark (the track jumped); a pass clears it (it was a one-frame outlier).
  bool jump_suspected = false;
  /// The last observation the filter used (initialization or update), [uL, vL, uR, vR], and the
  /// frame it came in (LandmarkManager::frame()): the reference of the next observation when
  /// the pixel error is correlated along the track (noise/pixel_correlation).
  Eigen::Vector4d previous_z = Eigen::Vector4d::Zero();
  int previous_frame = -1;
  double previous_stamp = 0.0;  ///< s, of previous_frame
  /// Stamp (s) of the frame that started this landmark: the age of an observation, over which
  /// the track has drifted (track_drift/), counts from it.
  double anchor_stamp = 0.0;
  /// Residual [rows of the observation] left after the last update that used this landmark, and
  /// its frame: the previous value of the track-correlation estimate (noise/).
  Eigen::VectorXd posterior_residual;
  int posterior_frame = -1;

  /// Age (s, never negative) of an observation of this landmark taken at `stamp`.
  double ageAt(double stamp) const { return std::max(0.0, stamp - anchor_stamp); }
};

/// Landmarks that leave the state after an update, decided by the updater, applied at once.
struct LandmarkDecisions {
  std::vector<size_t> restart;  ///< gated: start again from the current observation (same entry)
  std::vector<size_t> split;    ///< track too long: continue as a new landmark
  std::vector<size_t> jumped;   ///< track jumped: continue as a new landmark from the next frame
  bool empty() const { return restart.empty() && split.empty() && jumped.empty(); }
};

class LandmarkManager {
 public:
  static constexpr size_t kNewMapEntry = std::numeric_limits<size_t>::max();

  explicit LandmarkManager(const VislamOptions& options);

  void clear();
  size_t activeCount() const { return tracks_.size(); }
  LandmarkTrack& track(size_t k) { return tracks_[k]; }
  const LandmarkTrack& track(size_t k) const { return tracks_[k]; }
  /// State index of the landmark of a tracked id.
  std::optional<size_t> find(uint32_t id) const;
  const std::vector<LandmarkEstimate>& map() const { return map_; }
  LandmarkEstimate& mapEntry(size_t k) { return map_[tracks_[k].map_index]; }

  /// Triangulates `f` from the current pose and appends the landmark to the state (correlated
  /// with the pose and the calibration states it depends on). reuse_map_index: overwrite that
  /// map entry (a restart) instead of adding one. False (reason counted) when the disparity or
  /// depth is out of range.
  bool initialize(const StereoObservation& f, double stamp, size_t reuse_map_index,
                  const StereoCamera& camera, FilterState* state, EstimatorStats* stats,
                  FeedResult* result);
  /// Counts a feature frame (repeated frames included): frame() numbers the frames.
  void beginFrame(double stamp) {
    ++frame_;
    frame_stamp_ = stamp;
  }
  int frame() const { return frame_; }
  double frameStamp() const { return frame_stamp_; }
  /// Observation f of landmark k was used in the current frame.
  void recordUsed(size_t k, const StereoObservation& f);
  /// Flow reference of landmark k from observation f at the current state (track-jump test).
  void setFlowReference(size_t k, const StereoObservation& f, const StereoCamera& camera,
                        const FilterState& state);

  /// Counts the frame for the tracks present in it and the absence of the others (a non-empty
  /// frame only); returns the flags of the tracks absent beyond landmarks/max_track_gap.
  std::vector<bool> endedTracks(const std::unordered_set<uint32_t>& present, bool frame_empty);
  /// Ended tracks leave the state, or stay untracked with keep_all_landmarks_in_state.
  /// Returns how many left.
  int endTracks(const std::vector<bool>& ended, FilterState* state, EstimatorStats* stats);
  /// Removes the flagged landmarks from the state (their final estimate stays in the map) and
  /// renumbers the others.
  void remove(const std::vector<bool>& flags, bool count_as_marginalized, FilterState* state,
              EstimatorStats* stats);
  /// Applies the updater's decisions: every listed landmark leaves the state at once.
  void apply(const LandmarkDecisions& decisions, FilterState* state, EstimatorStats* stats,
             FeedResult* result);

  /// Means and covariances of the active landmarks into the map; tracks seen now get
  /// last_stamp = time.
  void syncMap(const FilterState& state, double time);

 private:
  /// Covariance of the world error of landmark k: dp = xi - p^ phi in SLAM mode; in mapping mode
  /// its state is conditioned on the dead-reckoned pose, whose error moves it by rho - p^ phi too.
  Eigen::Matrix3d covariance(const FilterState& state, size_t k) const;
  void syncEntry(const FilterState& state, size_t k);

  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
  Eigen::MatrixXd observation_selector_;
  std::vector<LandmarkTrack> tracks_;
  std::unordered_map<uint32_t, size_t> tracking_;  ///< tracked id -> state index
  std::vector<LandmarkEstimate> map_;
  int frame_ = 0;
  double frame_stamp_ = 0.0;
};

}  // namespace ekf_vislam
