#include "ekf_vislam/core/landmark_drift.h"

#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/stereo_camera.h"

#include <algorithm>

namespace ekf_vislam {
namespace landmark_drift {

Eigen::Matrix3d acrossRayCovariance(const Eigen::Matrix3d& R_world_cam,
                                    const Eigen::Vector3d& p_cam, double fx, double fy,
                                    double pixel_variance, double min_depth) {
  const double z = std::max(p_cam.z(), min_depth);
  const Eigen::Vector3d variance_cam(z * z / (fx * fx) * pixel_variance,
                                     z * z / (fy * fy) * pixel_variance, 0.0);
  return R_world_cam * variance_cam.asDiagonal() * R_world_cam.transpose();
}

void apply(const StereoCamera& camera, double random_walk_px, double dt, FilterState* state) {
  const size_t count = state->landmarkCount();
  if (!(random_walk_px > 0.0) || !(dt > 0.0) || count == 0) return;
  const Eigen::Matrix4d cam_T_world = camera.camTImu() * state->imu_T_world;
  const Eigen::Matrix3d R_cam_world = cam_T_world.topLeftCorner<3, 3>();
  const Eigen::Matrix3d R_world_cam = R_cam_world.transpose();
  const double fx = camera.Ks()(0, 0);
  const double fy = camera.Ks()(1, 1);
  const double pixel_variance = random_walk_px * random_walk_px * dt;
  for (size_t k = 0; k < count; ++k) {
    const Eigen::Vector3d p_cam =
        R_cam_world * state->landmark(k) + cam_T_world.topRightCorner<3, 1>();
    const Eigen::Matrix3d Q = acrossRayCovariance(R_world_cam, p_cam, fx, fy, pixel_variance);
    const int row = state->layout().landmarkRow(k);
    for (int which = 0; which < state->covarianceCount(); ++which) {
      state->covariance(which).block<3, 3>(row, row) += Q;
    }
  }
}

}  // namespace landmark_drift
}  // namespace ekf_vislam
