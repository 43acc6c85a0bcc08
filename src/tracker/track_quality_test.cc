#include "ekf_vislam/tracker/track_quality.h"

#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>
#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

const StereoCalibration kCamera = rectifiedPair(700.0, 700.0, 600.0, 180.0, 0.5);

// The left camera moving forward along its optical axis by `step` m per frame.
Eigen::Matrix4d forwardPose(int frame, double step) {
  Eigen::Matrix4d world_T_cam = Eigen::Matrix4d::Identity();
  world_T_cam(2, 3) = frame * step;
  return world_T_cam;
}

// A feature of the static world point p_world seen from world_T_cam, its right point shifted by
// `right_shift_px` (a disparity error of -right_shift_px).
TrackedFeature observe(uint32_t id, const Eigen::Vector3d& p_world,
                       const Eigen::Matrix4d& world_T_cam, double right_shift_px = 0.0) {
  const Eigen::Vector3d p_cam = (world_T_cam.inverse() * p_world.homogeneous()).head<3>();
  const Eigen::Vector2d left = project(kCamera, p_cam);
  TrackedFeature f;
  f.id = id;
  f.left = cv::Point2f(static_cast<float>(left.x()), static_cast<float>(left.y()));
  const double disparity = disparityAtDepth(kCamera, p_cam.z());
  f.right = cv::Point2f(static_cast<float>(left.x() - disparity + right_shift_px), f.left.y);
  return f;
}

TEST(TrackQuality, ExactTracksHaveNoErrorAndTheirCountsAndLengths) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> lateral(-8.0, 8.0), depth(15.0, 40.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 30; ++i) points.emplace_back(lateral(rng), 0.2 * lateral(rng), depth(rng));
  // Points 0-9 seen in frames 0-5 (6 frames), 10-29 in frames 0-2 (3 frames).
  std::vector<StereoFrame> frames(6);
  std::vector<Eigen::Matrix4d> poses;
  for (int k = 0; k < 6; ++k) {
    poses.push_back(forwardPose(k, 1.0));
    for (int i = 0; i < 30; ++i) {
      if (i < 10 || k < 3) frames[k].features.push_back(observe(i, points[i], poses.back()));
    }
  }
  const TrackQuality quality = evaluateTrackQuality(frames, poses, kCamera, 4);
  ASSERT_EQ(quality.median_error_px.size(), 4u);  // ages 1-4; age 5 beyond max_age
  for (const auto& [age, error] : quality.median_error_px) EXPECT_LT(error, 1e-3) << age;
  EXPECT_EQ(quality.samples.at(1), 30);
  EXPECT_EQ(quality.samples.at(2), 30);
  EXPECT_EQ(quality.samples.at(3), 10);
  EXPECT_EQ(quality.samples.at(4), 10);
  EXPECT_EQ(quality.num_tracks, 30);
  EXPECT_DOUBLE_EQ(quality.mean_track_length, (10 * 6 + 20 * 3) / 30.0);
  EXPECT_DOUBLE_EQ(quality.mean_observations_per_frame, (3 * 30 + 3 * 10) / 6.0);
  EXPECT_EQ(quality.min_observations_per_frame, 10);
}

TEST(TrackQuality, ADisparityErrorGivesTheErrorOfTheWrongDepth) {
  // One point 4 m right, 1 m down, 20 m ahead; the first disparity 1 px too small puts it
  // farther, and its reprojection falls short of the true pixel as the camera comes closer.
  const Eigen::Vector3d p_world(4.0, 1.0, 20.0);
  const double step = 1.5;
  std::vector<StereoFrame> frames(4);
  std::vector<Eigen::Matrix4d> poses;
  for (int k = 0; k < 4; ++k) {
    poses.push_back(forwardPose(k, step));
    frames[k].features.push_back(observe(7, p_world, poses.back(), k == 0 ? 1.0 : 0.0));
  }
  const TrackQuality quality = evaluateTrackQuality(frames, poses, kCamera, 3);
  const TrackedFeature first = frames[0].features[0];
  const double wrong_depth =
      kCamera.fx * kCamera.baseline / (disparityAtDepth(kCamera, p_world.z()) - 1.0);
  const Eigen::Vector3d p_wrong = wrong_depth * normalized(kCamera, first.left);
  double previous = 0.0;
  for (int age = 1; age <= 3; ++age) {
    const Eigen::Vector3d seen_wrong = p_wrong - Eigen::Vector3d(0, 0, age * step);
    const Eigen::Vector3d seen_true = p_world - Eigen::Vector3d(0, 0, age * step);
    const double expected = (project(kCamera, seen_wrong) - project(kCamera, seen_true)).norm();
    EXPECT_NEAR(quality.median_error_px.at(age), expected, 2e-3) << age;
    EXPECT_GT(quality.median_error_px.at(age), previous + 0.1) << age;  // grows with age
    previous = quality.median_error_px.at(age);
  }
}

TEST(TrackQuality, ATrackWithoutPositiveDisparityIsCountedButNotMeasured) {
  const Eigen::Vector3d p_world(1.0, 0.5, 30.0);
  std::vector<StereoFrame> frames(3);
  std::vector<Eigen::Matrix4d> poses;
  for (int k = 0; k < 3; ++k) {
    poses.push_back(forwardPose(k, 1.0));
    TrackedFeature f = observe(3, p_world, poses.back());
    if (k == 0) f.right.x = f.left.x + 0.5f;  // negative disparity at its start
    frames[k].features.push_back(f);
  }
  const TrackQuality quality = evaluateTrackQuality(frames, poses, kCamera, 5);
  EXPECT_TRUE(quality.median_error_px.empty());
  EXPECT_EQ(quality.num_tracks, 1);
  EXPECT_DOUBLE_EQ(quality.mean_track_length, 3.0);
}

}  // namespace
}  // namespace ekf_vislam
