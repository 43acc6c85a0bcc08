// A body twist derived from ground-truth poses, as an "accurate twist" sensor would give it
// (white noise per sample and a constant gyro offset, seeded), for complete course datasets
// made from image folders. No ROS.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace ekf_vislam {

/// cam_T_imu of an IMU frame with x forward, y left, z up, at the origin of the left camera's
/// optical frame (z forward, x right, y down).
Eigen::Matrix4d forwardLeftUpCamTImu();

/// cam_T_imu of a vehicle frame at the left camera's origin: x along the direction the camera
/// travels (the sum of its steps' body velocities: each step's SE(3) logarithm, in the camera frame
/// it starts from), z up (the camera's -y
/// made orthogonal to x), y left. A ground vehicle's body velocity lies along this x, so the
/// estimator's vehicle prior (no lateral or vertical velocity) holds for a twist in these axes; in
/// the camera's own axes it would not, for a camera pitched or turned against the direction of
/// travel (KITTI's cam0: 1.25 degrees of pitch on odometry 06). forwardLeftUpCamTImu() when the
/// poses travel less than `min_distance` m or mostly backwards.
Eigen::Matrix4d travelAlignedCamTImu(const std::vector<Eigen::Matrix4d>& world_T_cam,
                                     double min_distance = 1.0);

struct TwistNoise {
  double linear_sigma = 0.05;    ///< m/s, white, per sample and axis
  double angular_sigma = 0.005;  ///< rad/s, white, per sample and axis
  double gyro_offset = 0.001;    ///< rad/s, constant, added to every axis
  uint64_t seed = 0;
};

/// Body-frame twist (v, w) of world_T_body, one sample per pose: sample k+1 is the constant twist
/// that moves pose k to pose k+1 over [t_k, t_k+1] (log(body_k_T_body_k+1) / dt); sample 0 copies
/// sample 1. Noise is added as described by `noise` (all zero: the exact twist).
void twistFromPoses(const std::vector<Eigen::Matrix4d>& world_T_body,
                    const std::vector<double>& times, const TwistNoise& noise,
                    std::vector<Eigen::Vector3d>* v, std::vector<Eigen::Vector3d>* w);

}  // namespace ekf_vislam
