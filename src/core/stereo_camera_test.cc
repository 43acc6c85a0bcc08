#include "ekf_vislam/core/stereo_camera.h"

#include "ekf_vislam/core/se3.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <random>

namespace ekf_vislam {
namespace {

class StereoCameraTest : public ::testing::Test {
 protected:
  StereoCamera camera_{testing::kittiLikeCalibration()};
  // Pose with a point ~15 m in front of the camera.
  Eigen::Matrix4d imu_T_world_ =
      se3::exp((Vector6d() << 1.0, -2.0, 0.5, 0.05, -0.1, 0.3).finished());
  Eigen::Vector3d p_world() const {
    const Eigen::Vector4d p_imu(15.0, 2.0, 0.5, 1.0);
    return (se3::inverse(imu_T_world_) * p_imu).head<3>();
  }
};

TEST_F(StereoCameraTest, ProjectionJacobiansMatchCentralDifferences) {
  Eigen::Vector4d z;
  Matrix46d H_pose;
  Matrix43d H_landmark;
  ASSERT_TRUE(camera_.project(imu_T_world_, p_world(), &z, &H_pose, &H_landmark));
  const double h = 1e-6;
  Matrix46d numeric_pose;
  for (int i = 0; i < 6; ++i) {
    Vector6d d = Vector6d::Zero();
    d(i) = h;
    Eigen::Vector4d zp, zm;
    // world_T_imu = exp(d^) world_T_imu_mean  <=>  imu_T_world = imu_T_world_mean exp(-d^).
    camera_.project(imu_T_world_ * se3::exp(-d), p_world(), &zp);
    camera_.project(imu_T_world_ * se3::exp(d), p_world(), &zm);
    numeric_pose.col(i) = (zp - zm) / (2 * h);
  }
  EXPECT_LT((H_pose - numeric_pose).norm(), 1e-5 * H_pose.norm());
  Matrix43d numeric_landmark;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(i) = h;
    Eigen::Vector4d zp, zm;
    camera_.project(imu_T_world_, p_world() + d, &zp);
    camera_.project(imu_T_world_, p_world() - d, &zm);
    numeric_landmark.col(i) = (zp - zm) / (2 * h);
  }
  EXPECT_LT((H_landmark - numeric_landmark).norm(), 1e-5 * H_landmark.norm());
}

TEST_F(StereoCameraTest, ProjectionIsRectifiedStereo) {
  Eigen::Vector4d z;
  ASSERT_TRUE(camera_.project(imu_T_world_, p_world(), &z));
  EXPECT_NEAR(z(1), z(3), 1e-12);  // same row
  const Eigen::Vector4d p_cam = camera_.camTImu() * imu_T_world_ * p_world().homogeneous();
  EXPECT_NEAR(z(0) - z(2), 707.0912 * 0.5371506532679237 / p_cam(2), 1e-9);  // disparity
}

TEST_F(StereoCameraTest, PointBehindCameraIsRefused) {
  Eigen::Vector4d z;
  const Eigen::Vector4d p_imu(-10.0, 0.0, 0.0, 1.0);
  EXPECT_FALSE(camera_.project(imu_T_world_, (se3::inverse(imu_T_world_) * p_imu).head<3>(), &z));
}

TEST_F(StereoCameraTest, TriangulationInvertsProjection) {
  Eigen::Vector4d z;
  ASSERT_TRUE(camera_.project(imu_T_world_, p_world(), &z));
  Eigen::Vector3d p_cam;
  ASSERT_TRUE(camera_.triangulate(z(0), z(1), z(2), &p_cam));
  const Eigen::Vector4d expected = camera_.camTImu() * imu_T_world_ * p_world().homogeneous();
  EXPECT_LT((p_cam - expected.head<3>()).norm(), 1e-9);
  EXPECT_FALSE(camera_.triangulate(500.0, 100.0, 501.0, &p_cam));  // negative disparity
  EXPECT_FALSE(camera_.triangulate(500.0, 100.0, 500.0, &p_cam));  // zero disparity
}

TEST_F(StereoCameraTest, TriangulationJacobianMatchesCentralDifferences) {
  const Eigen::Vector3d uvu(700.0, 150.0, 680.0);
  Eigen::Vector3d p;
  Eigen::Matrix3d J;
  ASSERT_TRUE(camera_.triangulate(uvu(0), uvu(1), uvu(2), &p, &J));
  Eigen::Matrix3d numeric;
  const double h = 1e-5;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(i) = h;
    Eigen::Vector3d pp, pm;
    camera_.triangulate(uvu(0) + d(0), uvu(1) + d(1), uvu(2) + d(2), &pp);
    camera_.triangulate(uvu(0) - d(0), uvu(1) - d(1), uvu(2) - d(2), &pm);
    numeric.col(i) = (pp - pm) / (2 * h);
  }
  EXPECT_LT((J - numeric).norm(), 1e-6 * J.norm());
}

TEST_F(StereoCameraTest, TriangulationCovarianceMatchesMonteCarlo) {
  // A near point (small relative disparity noise) so that first order holds.
  const Eigen::Vector3d uvu(700.0, 150.0, 660.0);  // 40 px disparity, ~9.5 m
  const double sigma = 0.5;
  Eigen::Vector3d p0;
  Eigen::Matrix3d J;
  ASSERT_TRUE(camera_.triangulate(uvu(0), uvu(1), uvu(2), &p0, &J));
  const Eigen::Matrix3d predicted = sigma * sigma * J * J.transpose();
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, sigma);
  const int samples = 200000;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (int i = 0; i < samples; ++i) {
    Eigen::Vector3d p;
    camera_.triangulate(uvu(0) + n(rng), uvu(1) + n(rng), uvu(2) + n(rng), &p);
    mean += p;
    second += p * p.transpose();
  }
  mean /= samples;
  const Eigen::Matrix3d empirical = second / samples - mean * mean.transpose();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(std::sqrt(empirical(i, i)), std::sqrt(predicted(i, i)),
                0.03 * std::sqrt(predicted(i, i)))
        << "axis " << i;
  }
}

TEST(StereoCalibration, ValidateNamesTheProblem) {
  StereoCalibration c = testing::kittiLikeCalibration();
  EXPECT_EQ(c.validate(), "");
  StereoCalibration bad = c;
  bad.fx = 0.0;
  EXPECT_NE(bad.validate().find("focal"), std::string::npos);
  bad = c;
  bad.baseline = -0.5;
  EXPECT_NE(bad.validate().find("baseline"), std::string::npos);
  bad = c;
  bad.cam_T_imu.linear() *= 2.0;
  EXPECT_NE(bad.validate().find("rotation"), std::string::npos);
  bad = c;
  bad.cx = std::nan("");
  EXPECT_NE(bad.validate(), "");
}

}  // namespace
}  // namespace ekf_vislam
