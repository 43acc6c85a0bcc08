#include "ekf_vislam/ros/landmark_markers.h"

#include <gtest/gtest.h>

#include <limits>

namespace ekf_vislam {
namespace {

LandmarkEstimate landmark(double x, double sigma, bool active, bool confirmed = true) {
  LandmarkEstimate l;
  l.observations = confirmed ? 2 : 1;
  l.p_world = Eigen::Vector3d(x, 1.0, 2.0);
  l.covariance =
      Eigen::Vector3d(sigma * sigma, 0.25 * sigma * sigma, 0.01 * sigma * sigma).asDiagonal();
  l.active = active;
  return l;
}

const visualization_msgs::Marker* find(const visualization_msgs::MarkerArray& array,
                                       const std::string& ns, int id = 0) {
  for (const auto& m : array.markers) {
    if (m.ns == ns && m.id == id) return &m;
  }
  return nullptr;
}

TEST(LandmarkMarkers, SigmaColourRunsFromGreenThroughYellowToRed) {
  const auto good = ros_markers::sigmaColor(0.1, 0.25, 10.0);
  const auto half = ros_markers::sigmaColor(std::sqrt(0.25 * 10.0), 0.25, 10.0);
  const auto bad = ros_markers::sigmaColor(50.0, 0.25, 10.0);
  EXPECT_FLOAT_EQ(good.r, 0.0f);
  EXPECT_FLOAT_EQ(good.g, 1.0f);
  EXPECT_NEAR(half.r, 1.0f, 1e-6);
  EXPECT_NEAR(half.g, 1.0f, 1e-6);
  EXPECT_FLOAT_EQ(bad.r, 1.0f);
  EXPECT_FLOAT_EQ(bad.g, 0.0f);
}

TEST(LandmarkMarkers, EveryFiniteConfirmedLandmarkIsAPointAndActiveOnesAreDrawnAgain) {
  VislamRosOptions options;
  options.world_frame = "map";
  // Seen once: in the state (drawn as active) but not in the map; left behind: in neither.
  std::vector<LandmarkEstimate> landmarks = {
      landmark(1.0, 0.1, true), landmark(2.0, 20.0, false), landmark(3.0, 1.0, true),
      landmark(5.0, 0.1, true, /*confirmed=*/false), landmark(6.0, 0.1, false, false)};
  LandmarkEstimate broken = landmark(4.0, 1.0, true);
  broken.p_world.x() = std::numeric_limits<double>::quiet_NaN();
  landmarks.push_back(broken);
  size_t ellipsoids = 0;
  const auto array = ros_markers::landmarkMarkers(landmarks, ros::Time(12.5), options, &ellipsoids);
  const auto* map = find(array, "landmarks");
  const auto* active = find(array, "active_landmarks");
  ASSERT_NE(map, nullptr);
  ASSERT_NE(active, nullptr);
  EXPECT_EQ(map->header.frame_id, "map");
  EXPECT_DOUBLE_EQ(map->header.stamp.toSec(), 12.5);
  ASSERT_EQ(map->points.size(), 3u);  // the NaN one and the unconfirmed ones left out
  ASSERT_EQ(map->colors.size(), 3u);
  EXPECT_DOUBLE_EQ(map->points[2].x, 3.0);
  EXPECT_FLOAT_EQ(map->colors[0].g, 1.0f);  // 0.1 m: green
  EXPECT_FLOAT_EQ(map->colors[1].r, 1.0f);  // 20 m: red
  EXPECT_FLOAT_EQ(map->colors[1].g, 0.0f);
  ASSERT_EQ(active->points.size(), 3u);
  EXPECT_DOUBLE_EQ(active->points[1].x, 3.0);
  EXPECT_DOUBLE_EQ(active->points[2].x, 5.0);
  EXPECT_EQ(ellipsoids, 0u);
  EXPECT_EQ(find(array, "landmark_covariance"), nullptr);
}

TEST(LandmarkMarkers, EllipsoidsFollowTheCovarianceAndStaleOnesAreDeleted) {
  VislamRosOptions options;
  options.covariance_ellipsoids = true;
  options.ellipsoid_sigma_scale = 3.0;
  std::vector<LandmarkEstimate> landmarks = {landmark(1.0, 0.5, true), landmark(2.0, 1.0, true)};
  size_t ellipsoids = 5;  // the previous array drew five
  const auto array = ros_markers::landmarkMarkers(landmarks, ros::Time(1.0), options, &ellipsoids);
  EXPECT_EQ(ellipsoids, 2u);
  const auto* first = find(array, "landmark_covariance", 0);
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->action, visualization_msgs::Marker::ADD);
  // Half-axes 3 sigma along the eigenvectors: sigmas 0.5, 0.25, 0.05 -> diameters 3, 1.5, 0.3
  // (eigenvalues ascending).
  EXPECT_NEAR(first->scale.x, 0.3, 1e-9);
  EXPECT_NEAR(first->scale.y, 1.5, 1e-9);
  EXPECT_NEAR(first->scale.z, 3.0, 1e-9);
  EXPECT_DOUBLE_EQ(first->pose.position.x, 1.0);
  for (int id = 2; id < 5; ++id) {
    const auto* gone = find(array, "landmark_covariance", id);
    ASSERT_NE(gone, nullptr) << id;
    EXPECT_EQ(gone->action, visualization_msgs::Marker::DELETE);
  }
  EXPECT_EQ(find(array, "landmark_covariance", 5), nullptr);
}

TEST(LandmarkMarkers, AnEmptyMapDeletesItsPointMarkers) {
  size_t ellipsoids = 0;
  const auto array =
      ros_markers::landmarkMarkers({}, ros::Time(1.0), VislamRosOptions(), &ellipsoids);
  ASSERT_NE(find(array, "landmarks"), nullptr);
  EXPECT_EQ(find(array, "landmarks")->action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(find(array, "active_landmarks")->action, visualization_msgs::Marker::DELETE);
  const auto cleared = ros_markers::clearedMarkers(VislamRosOptions());
  ASSERT_EQ(cleared.markers.size(), 1u);
  EXPECT_EQ(cleared.markers[0].action, visualization_msgs::Marker::DELETEALL);
}

}  // namespace
}  // namespace ekf_vislam
