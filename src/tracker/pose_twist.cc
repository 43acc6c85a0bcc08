#include "ekf_vislam/tracker/pose_twist.h"

#include "ekf_vislam/core/se3.h"

#include <random>

namespace ekf_vislam {

Eigen::Matrix4d forwardLeftUpCamTImu() {
  Eigen::Matrix4d cam_T_imu = Eigen::Matrix4d::Identity();
  // Columns: the IMU axes in the camera frame. x forward = +z_cam, y left = -x_cam,
  // z up = -y_cam.
  cam_T_imu.block<3, 3>(0, 0) << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  return cam_T_imu;
}

Eigen::Matrix4d travelAlignedCamTImu(const std::vector<Eigen::Matrix4d>& world_T_cam,
                                     double min_distance) {
  // The body velocity of each step (its SE(3) logarithm, in the camera frame it starts from): in
  // a turn the chord of a step leans half the step's rotation into the turn, the velocity does not.
  Eigen::Vector3d travel_cam = Eigen::Vector3d::Zero();
  double distance = 0.0;
  for (size_t k = 0; k + 1 < world_T_cam.size(); ++k) {
    const Eigen::Vector3d step_cam =
        se3::log(se3::inverse(world_T_cam[k]) * world_T_cam[k + 1]).head<3>();
    travel_cam += step_cam;
    distance += step_cam.norm();
  }
  Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  // Mostly forward along the optical axis (z): otherwise the camera's own axes are kept.
  if (!(distance >= min_distance) || !(travel_cam.z() > 0.5 * travel_cam.norm())) return cam_T_imu;
  const Eigen::Vector3d x = travel_cam.normalized();
  const Eigen::Vector3d up_cam(0.0, -1.0, 0.0);
  const Eigen::Vector3d z = (up_cam - up_cam.dot(x) * x).normalized();
  cam_T_imu.block<3, 1>(0, 0) = x;
  cam_T_imu.block<3, 1>(0, 1) = z.cross(x);
  cam_T_imu.block<3, 1>(0, 2) = z;
  return cam_T_imu;
}

void twistFromPoses(const std::vector<Eigen::Matrix4d>& world_T_body,
                    const std::vector<double>& times, const TwistNoise& noise,
                    std::vector<Eigen::Vector3d>* v, std::vector<Eigen::Vector3d>* w) {
  const size_t n = std::min(world_T_body.size(), times.size());
  v->assign(n, Eigen::Vector3d::Zero());
  w->assign(n, Eigen::Vector3d::Zero());
  for (size_t k = 0; k + 1 < n; ++k) {
    const double dt = times[k + 1] - times[k];
    if (dt <= 0) continue;
    const Vector6d xi = se3::log(se3::inverse(world_T_body[k]) * world_T_body[k + 1]) / dt;
    (*v)[k + 1] = xi.head<3>();
    (*w)[k + 1] = xi.tail<3>();
  }
  if (n >= 2) {
    (*v)[0] = (*v)[1];
    (*w)[0] = (*w)[1];
  }
  std::mt19937_64 generator(noise.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (size_t k = 0; k < n; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      (*v)[k][axis] += noise.linear_sigma * normal(generator);
      (*w)[k][axis] += noise.angular_sigma * normal(generator) + noise.gyro_offset;
    }
  }
}

}  // namespace ekf_vislam
