#include "ekf_vislam/ros/landmark_markers.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace ekf_vislam {
namespace ros_markers {

namespace {

std_msgs::ColorRGBA color(float r, float g, float b, float a) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point point;
  point.x = p.x();
  point.y = p.y();
  point.z = p.z();
  return point;
}

/// The covariance ellipsoid of one landmark; false when its covariance has no eigenbasis.
bool ellipsoid(const LandmarkEstimate& landmark, const std_msgs::Header& header, int id,
               double sigma_scale, visualization_msgs::Marker* sphere) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(landmark.covariance);
  if (solver.info() != Eigen::Success) return false;
  Eigen::Matrix3d axes = solver.eigenvectors();
  if (axes.determinant() < 0.0) axes.col(2) *= -1.0;
  const Eigen::Quaterniond q(axes);
  sphere->header = header;
  sphere->ns = "landmark_covariance";
  sphere->id = id;
  sphere->type = visualization_msgs::Marker::SPHERE;
  sphere->action = visualization_msgs::Marker::ADD;
  sphere->pose.position = toPoint(landmark.p_world);
  sphere->pose.orientation.x = q.x();
  sphere->pose.orientation.y = q.y();
  sphere->pose.orientation.z = q.z();
  sphere->pose.orientation.w = q.w();
  const Eigen::Vector3d size = 2.0 * sigma_scale * solver.eigenvalues().cwiseMax(1e-8).cwiseSqrt();
  sphere->scale.x = size.x();
  sphere->scale.y = size.y();
  sphere->scale.z = size.z();
  sphere->color = color(1.0f, 0.6f, 0.0f, 0.35f);
  return true;
}

}  // namespace

std_msgs::ColorRGBA sigmaColor(double sigma, double good, double bad) {
  double t = std::log(std::max(sigma, 1e-12) / good) / std::log(bad / good);
  if (!std::isfinite(t)) t = 1.0;
  t = std::min(1.0, std::max(0.0, t));
  return color(static_cast<float>(std::min(1.0, 2.0 * t)),
               static_cast<float>(std::min(1.0, 2.0 * (1.0 - t))), 0.0f, 1.0f);
}

visualization_msgs::MarkerArray landmarkMarkers(const std::vector<LandmarkEstimate>& landmarks,
                                                const ros::Time& stamp,
                                                const VislamRosOptions& options,
                                                size_t* ellipsoid_count) {
  visualization_msgs::Marker map;
  map.header.frame_id = options.world_frame;
  map.header.stamp = stamp;
  map.ns = "landmarks";
  map.id = 0;
  map.type = visualization_msgs::Marker::POINTS;
  map.pose.orientation.w = 1.0;
  map.scale.x = map.scale.y = options.landmark_point_size;
  map.color = color(0.0f, 1.0f, 0.0f, 1.0f);
  visualization_msgs::Marker active = map;
  active.ns = "active_landmarks";
  active.scale.x = active.scale.y = 2.0 * options.landmark_point_size;
  active.color = color(0.1f, 0.6f, 1.0f, 1.0f);

  map.points.reserve(landmarks.size());
  map.colors.reserve(landmarks.size());
  std::vector<const LandmarkEstimate*> active_landmarks;
  for (const LandmarkEstimate& landmark : landmarks) {
    if (!landmark.p_world.allFinite() || !landmark.covariance.allFinite()) continue;
    if (landmark.confirmed()) {  // the map: seen twice or more (LandmarkEstimate::confirmed)
      const double sigma = std::sqrt(std::max(0.0, landmark.covariance.diagonal().maxCoeff()));
      map.points.push_back(toPoint(landmark.p_world));
      map.colors.push_back(
          sigmaColor(sigma, options.landmark_sigma_good, options.landmark_sigma_bad));
    }
    if (landmark.active) {  // the filter's state, confirmed or not
      active.points.push_back(toPoint(landmark.p_world));
      active_landmarks.push_back(&landmark);
    }
  }
  visualization_msgs::MarkerArray array;
  for (visualization_msgs::Marker* marker : {&map, &active}) {
    marker->action = marker->points.empty() ? visualization_msgs::Marker::DELETE
                                            : visualization_msgs::Marker::ADD;
    array.markers.push_back(*marker);
  }

  size_t drawn = 0;
  if (options.covariance_ellipsoids) {
    for (const LandmarkEstimate* landmark : active_landmarks) {
      visualization_msgs::Marker sphere;
      if (ellipsoid(*landmark, map.header, static_cast<int>(drawn), options.ellipsoid_sigma_scale,
                    &sphere)) {
        array.markers.push_back(sphere);
        ++drawn;
      }
    }
  }
  for (size_t id = drawn; id < *ellipsoid_count; ++id) {
    visualization_msgs::Marker gone;
    gone.header = map.header;
    gone.ns = "landmark_covariance";
    gone.id = static_cast<int>(id);
    gone.action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(gone);
  }
  *ellipsoid_count = drawn;
  return array;
}

visualization_msgs::MarkerArray clearedMarkers(const VislamRosOptions& options) {
  visualization_msgs::MarkerArray array;
  visualization_msgs::Marker clear;
  clear.header.frame_id = options.world_frame;
  clear.action = visualization_msgs::Marker::DELETEALL;
  array.markers.push_back(clear);
  return array;
}

}  // namespace ros_markers
}  // namespace ekf_vislam
