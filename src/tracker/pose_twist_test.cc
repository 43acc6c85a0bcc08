#include "ekf_vislam/tracker/pose_twist.h"
#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ekf_vislam {
namespace {

TEST(PoseTwist, CamTImuAxes) {
  const Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  const Eigen::Matrix3d R = cam_T_imu.block<3, 3>(0, 0);
  EXPECT_TRUE(R.col(0).isApprox(Eigen::Vector3d(0, 0, 1)));   // forward = camera z
  EXPECT_TRUE(R.col(1).isApprox(Eigen::Vector3d(-1, 0, 0)));  // left = -camera x
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d(0, -1, 0)));  // up = -camera y
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

// A camera pitched and turned against its travel, in a turn: the vehicle frame's x is the travel
// (no lateral or vertical velocity in it), its z the camera's up made orthogonal; without travel
// (or backwards) the camera's own axes.
TEST(PoseTwist, VehicleFrameFollowsTheTravel) {
  const Eigen::Matrix3d mount = se3::expSO3(Eigen::Vector3d(0.026, 0.0, 0.0)) *
                                se3::expSO3(Eigen::Vector3d(0.0, -0.012, 0.0));
  // The vehicle (in camera-like axes: z its travel, y down) drives at 12 m/s through a turn of
  // 0.3 rad/s; a step's chord leans 0.9 degrees into the turn, its velocity stays along z.
  Vector6d xi;
  xi << 0.0, 0.0, 12.0, 0.0, -0.3, 0.0;
  Eigen::Matrix4d mount_T = Eigen::Matrix4d::Identity();
  mount_T.block<3, 3>(0, 0) = mount;
  std::vector<Eigen::Matrix4d> world_T_cam;
  for (int k = 0; k < 20; ++k) world_T_cam.push_back(se3::exp(0.1 * k * xi) * mount_T);
  const Eigen::Matrix4d cam_T_imu = travelAlignedCamTImu(world_T_cam);
  const Eigen::Matrix3d R = cam_T_imu.block<3, 3>(0, 0);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_LT((R.col(0) - mount.transpose() * Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(R.col(1).y(), 0.0, 1e-12);  // left is level in the camera: no roll about x
  EXPECT_LT(R.col(2).y(), -0.99);         // up = the camera's -y
  std::vector<Eigen::Matrix4d> world_T_imu;
  for (const Eigen::Matrix4d& pose : world_T_cam) world_T_imu.push_back(pose * cam_T_imu);
  std::vector<double> times;
  for (int k = 0; k < 20; ++k) times.push_back(0.1 * k);
  TwistNoise exact;
  exact.linear_sigma = exact.angular_sigma = exact.gyro_offset = 0;
  std::vector<Eigen::Vector3d> v, w;
  twistFromPoses(world_T_imu, times, exact, &v, &w);
  for (const Eigen::Vector3d& sample : v) {
    EXPECT_LT((sample - Eigen::Vector3d(12.0, 0.0, 0.0)).norm(), 1e-9);
  }
  // In the camera's own axes the pitch shows as vertical velocity: 12 m/s x sin(0.026).
  world_T_imu.clear();
  for (const Eigen::Matrix4d& pose : world_T_cam)
    world_T_imu.push_back(pose * forwardLeftUpCamTImu());
  twistFromPoses(world_T_imu, times, exact, &v, &w);
  EXPECT_GT(std::abs(v[5].z()), 0.3);

  const std::vector<Eigen::Matrix4d> still(5, world_T_cam.front());
  EXPECT_EQ(travelAlignedCamTImu(still), forwardLeftUpCamTImu());
  std::vector<Eigen::Matrix4d> backwards(world_T_cam.rbegin(), world_T_cam.rend());
  EXPECT_EQ(travelAlignedCamTImu(backwards), forwardLeftUpCamTImu());
}

TEST(PoseTwist, RecoversTheTwistThatMovedThePoses) {
  std::vector<Eigen::Matrix4d> poses{Eigen::Matrix4d::Identity()};
  std::vector<double> times{0.0};
  std::vector<Vector6d> truth(1);
  for (int k = 1; k < 20; ++k) {
    Vector6d xi;
    xi << 5 + 0.1 * k, 0.2, -0.1, 0.01, -0.02, 0.05 * std::sin(k);
    const double dt = 0.1 + 0.003 * k;
    times.push_back(times.back() + dt);
    poses.push_back(poses.back() * se3::exp(xi * dt));
    truth.push_back(xi);
  }
  std::vector<Eigen::Vector3d> v, w;
  TwistNoise exact;
  exact.linear_sigma = exact.angular_sigma = exact.gyro_offset = 0;
  twistFromPoses(poses, times, exact, &v, &w);
  for (int k = 1; k < 20; ++k) {
    EXPECT_LT((v[k] - truth[k].head<3>()).norm(), 1e-9) << k;
    EXPECT_LT((w[k] - truth[k].tail<3>()).norm(), 1e-9) << k;
  }
  EXPECT_TRUE(v[0].isApprox(v[1]));

  // Noise: the documented std and offset, reproducible from the seed.
  std::vector<Eigen::Vector3d> v1, w1, v2, w2;
  TwistNoise noise;
  noise.seed = 5;
  std::vector<Eigen::Matrix4d> still(4000, Eigen::Matrix4d::Identity());
  std::vector<double> still_times(4000);
  for (size_t k = 0; k < still_times.size(); ++k) still_times[k] = 0.1 * k;
  twistFromPoses(still, still_times, noise, &v1, &w1);
  twistFromPoses(still, still_times, noise, &v2, &w2);
  double sum_v2 = 0, sum_w = 0, sum_w2 = 0;
  for (size_t k = 0; k < v1.size(); ++k) {
    EXPECT_EQ(v1[k], v2[k]);
    sum_v2 += v1[k].squaredNorm();
    sum_w += w1[k].sum();
    sum_w2 += (w1[k].array() - noise.gyro_offset).matrix().squaredNorm();
  }
  const double n = 3.0 * v1.size();
  EXPECT_NEAR(std::sqrt(sum_v2 / n), 0.05, 0.002);
  EXPECT_NEAR(sum_w / n, 0.001, 0.0002);
  EXPECT_NEAR(std::sqrt(sum_w2 / n), 0.005, 0.0002);
}

}  // namespace
}  // namespace ekf_vislam
