// Which column of a course dataset's features array (4, M, T) holds each track id. The course
// layout gives every id a column of its own, which grows as ids x frames: a tracker that starts
// 60 ids a frame fills 4 x 65000 x 1100 doubles (2.3 GB) over a KITTI sequence of 1100 frames.
// An id's column can be taken again by a later id once it has stayed unobserved for a while: the
// estimator ends a track after landmarks/max_track_gap frames without it and starts the id that
// comes back as a new landmark (ekf_vislam/StereoFeature), and the tools split a column into its
// runs of consecutive frames. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace ekf_vislam {

/// Frames a column stays unobserved before another id takes it (far more than the estimator's
/// default landmarks/max_track_gap, 2), when columns are shared.
constexpr size_t kColumnReuseGap = 10;
/// Bytes of the features array with a column per id beyond which track_stereo_images shares
/// columns unless told otherwise.
constexpr double kFreshColumnsMaxBytes = 1024.0 * 1024.0 * 1024.0;

struct FeatureColumns {
  std::unordered_map<uint32_t, size_t> column_of_id;
  size_t columns = 0;  ///< M
};

/// Columns for the ids of `frames`, each id seen in one run of frames (the tracker never gives
/// an id twice). reuse_gap 0: a column per id, in increasing id order (the course files'
/// layout). Otherwise, in order of first frame, an id takes the column that has been free the
/// longest once reuse_gap frames have passed after its last observation, else a new column.
FeatureColumns assignFeatureColumns(const std::vector<StereoFrame>& frames, size_t reuse_gap);

/// Bytes of the float64 features array (4, ids, frames) with a column per id.
inline double freshColumnsBytes(size_t ids, size_t frames) { return 32.0 * ids * frames; }
/// The gap track_stereo_images uses unless told: 0 (a column per id) while that array stays
/// within kFreshColumnsMaxBytes, else kColumnReuseGap.
inline size_t defaultReuseGap(size_t ids, size_t frames) {
  return freshColumnsBytes(ids, frames) <= kFreshColumnsMaxBytes ? 0 : kColumnReuseGap;
}

}  // namespace ekf_vislam
