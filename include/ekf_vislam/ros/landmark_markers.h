// The landmark map as rviz markers: every landmark a point coloured by its uncertainty, the
// landmarks in the filter state larger, and optionally their covariance ellipsoids.
#pragma once

#include "ekf_vislam/core/types.h"
#include "ekf_vislam/ros/vislam_ros_options.h"

#include <ros/time.h>
#include <std_msgs/ColorRGBA.h>
#include <visualization_msgs/MarkerArray.h>

#include <vector>

namespace ekf_vislam {
namespace ros_markers {

/// Green at or below `good`, yellow halfway (log scale), red at or above `bad`.
std_msgs::ColorRGBA sigmaColor(double sigma, double good, double bad);

/// Markers of `landmarks` (non-finite ones left out) in options.world_frame at `stamp`:
/// namespace "landmarks" (the map: the confirmed ones, coloured by their largest sigma),
/// "active_landmarks" (those in the state, confirmed or not) and, with
/// options.covariance_ellipsoids, "landmark_covariance" (one sphere per active landmark, half-axes
/// ellipsoid_sigma_scale sigma). Ellipsoid ids from a previous array that are no longer used (up to
/// *ellipsoid_count on entry) are deleted; *ellipsoid_count becomes the number drawn now.
visualization_msgs::MarkerArray landmarkMarkers(const std::vector<LandmarkEstimate>& landmarks,
                                                const ros::Time& stamp,
                                                const VislamRosOptions& options,
                                                size_t* ellipsoid_count);

/// One marker that clears every marker of the map.
visualization_msgs::MarkerArray clearedMarkers(const VislamRosOptions& options);

}  // namespace ros_markers
}  // namespace ekf_vislam
