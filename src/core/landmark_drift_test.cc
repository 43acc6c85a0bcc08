#include "ekf_vislam/core/landmark_drift.h"

#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

const Eigen::Matrix4d kImuTWorld =
    se3::exp((Vector6d() << 1.0, -2.0, 0.5, 0.05, -0.1, 0.3).finished());

// A point this far ahead of the IMU (x forward), a little off the camera's axis.
Eigen::Vector3d pointAhead(double distance) {
  const Eigen::Vector4d p_imu(distance, 2.0, 0.5, 1.0);
  return (se3::inverse(kImuTWorld) * p_imu).head<3>();
}

TEST(LandmarkDrift, MovesTheProjectionByThePixelStepAndKeepsTheDisparity) {
  const StereoCamera camera(testing::kittiLikeCalibration());
  for (const double distance : {4.0, 15.0, 60.0}) {
    const Eigen::Vector3d p_world = pointAhead(distance);
    Eigen::Vector4d z;
    Matrix43d H_landmark;
    Matrix46d H_pose;
    ASSERT_TRUE(camera.project(kImuTWorld, p_world, &z, &H_pose, &H_landmark));
    const Eigen::Matrix4d cam_T_world = camera.camTImu() * kImuTWorld;
    const Eigen::Vector3d p_cam =
        cam_T_world.topLeftCorner<3, 3>() * p_world + cam_T_world.topRightCorner<3, 1>();
    const double pixel_variance = 0.36;
    const Eigen::Matrix3d Q =
        landmark_drift::acrossRayCovariance(cam_T_world.topLeftCorner<3, 3>().transpose(), p_cam,
                                            camera.Ks()(0, 0), camera.Ks()(1, 1), pixel_variance);
    // uL and uR move together by the step (disparity fixed), vL with vR.
    Eigen::Matrix4d expected = Eigen::Matrix4d::Zero();
    for (int i : {0, 2}) {
      for (int j : {0, 2}) expected(i, j) = pixel_variance;
    }
    for (int i : {1, 3}) {
      for (int j : {1, 3}) expected(i, j) = pixel_variance;
    }
    const Eigen::Matrix4d pixel_covariance = H_landmark * Q * H_landmark.transpose();
    EXPECT_LT((pixel_covariance - expected).cwiseAbs().maxCoeff(), 1e-9 + 1e-6 * pixel_variance)
        << "at " << distance << " m:\n"
        << pixel_covariance;
    // Nothing along the ray: the depth of the point does not wander.
    const Eigen::Vector3d ray_world =
        cam_T_world.topLeftCorner<3, 3>().transpose() * Eigen::Vector3d::UnitZ();
    EXPECT_LT((Q * ray_world).norm(), 1e-12);
  }
}

TEST(LandmarkDrift, AddsToEveryLandmarkBlockOfEveryCovarianceOnly) {
  const StereoCamera camera(testing::kittiLikeCalibration());
  StateLayout layout;
  layout.reported_covariance = true;
  FilterState state(layout);
  state.reset(StatePrior());
  state.imu_T_world = kImuTWorld;
  for (const double distance : {8.0, 30.0}) {
    state.appendLandmark(pointAhead(distance), Eigen::MatrixXd::Zero(3, state.dim()),
                         Eigen::Matrix3d::Identity());
  }
  const Eigen::MatrixXd before = state.covariance(0);
  const Eigen::MatrixXd before_reported = state.covariance(1);

  landmark_drift::apply(camera, 2.0, 0.0, &state);  // no time, no drift
  landmark_drift::apply(camera, 0.0, 0.1, &state);  // no rate, no drift
  EXPECT_EQ((state.covariance(0) - before).cwiseAbs().maxCoeff(), 0.0);

  landmark_drift::apply(camera, 2.0, 0.09, &state);  // (2 px/sqrt(s))^2 0.09 s = 0.36 px^2
  const Eigen::Matrix4d cam_T_world = camera.camTImu() * kImuTWorld;
  for (int which = 0; which < 2; ++which) {
    Eigen::MatrixXd change = state.covariance(which) - (which == 0 ? before : before_reported);
    for (size_t k = 0; k < 2; ++k) {
      const int row = layout.landmarkRow(k);
      const Eigen::Vector3d p_cam = cam_T_world.topLeftCorner<3, 3>() * state.landmark(k) +
                                    cam_T_world.topRightCorner<3, 1>();
      const Eigen::Matrix3d Q =
          landmark_drift::acrossRayCovariance(cam_T_world.topLeftCorner<3, 3>().transpose(), p_cam,
                                              camera.Ks()(0, 0), camera.Ks()(1, 1), 0.36);
      EXPECT_LT((change.block<3, 3>(row, row) - Q).cwiseAbs().maxCoeff(), 1e-15);
      EXPECT_GT(Q.trace(), 0.0);
      change.block<3, 3>(row, row).setZero();
    }
    EXPECT_EQ(change.cwiseAbs().maxCoeff(), 0.0) << "covariance " << which;
  }
}

}  // namespace
}  // namespace ekf_vislam
