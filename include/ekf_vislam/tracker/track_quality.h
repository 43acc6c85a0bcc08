// Quality of stereo tracks against ground-truth camera poses: each track is triangulated from
// its first stereo observation with that frame's pose and reprojected into the left image of
// its later frames; the error is summarized by track age. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>

#include <map>
#include <string>
#include <vector>

namespace ekf_vislam {

struct TrackQuality {
  std::map<int, double> median_error_px;  ///< by age (frames since the track's first frame)
  std::map<int, int> samples;             ///< observations behind each median
  double mean_observations_per_frame = 0;
  int min_observations_per_frame = 0;
  double mean_track_length = 0;  ///< frames per track id
  int num_tracks = 0;
  std::string describe() const;
};

/// frames[k] holds the features of frame k; world_T_cam[k] its left camera pose (same count).
/// Errors are computed for the ages 1..max_age.
TrackQuality evaluateTrackQuality(const std::vector<StereoFrame>& frames,
                                  const std::vector<Eigen::Matrix4d>& world_T_cam,
                                  const StereoCalibration& calibration, int max_age);

}  // namespace ekf_vislam
