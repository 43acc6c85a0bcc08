// Rectified stereo camera model: z = Ks pi(cam_T_imu * imu_T_world * m), its Jacobians, and
// triangulation of a landmark from one stereo observation with its covariance. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

namespace ekf_vislam {

using Matrix46d = Eigen::Matrix<double, 4, 6>;
using Matrix43d = Eigen::Matrix<double, 4, 3>;

/// Rows of the stereo observation [uL, vL, uR, vR] the filter uses: [uL, (vL + vR) / 2, uR]
/// (merge_rows: vL and vR are one row of a rectified pair) or all four. Rows x 4.
Eigen::MatrixXd stereoObservationSelector(bool merge_rows);

class StereoCamera;
/// The camera of `nominal` with its baseline times (1 + baseline_scale_error).
StereoCamera scaledStereoCamera(const StereoCalibration& nominal, double baseline_scale_error);

class StereoCamera {
 public:
  StereoCamera() = default;
  explicit StereoCamera(const StereoCalibration& calibration);

  const StereoCalibration& calibration() const { return calibration_; }
  /// Ks = [[fx, 0, cx, 0], [0, fy, cy, 0], [fx, 0, cx, -fx b], [0, fy, cy, 0]].
  const Eigen::Matrix4d& Ks() const { return Ks_; }
  const Eigen::Matrix4d& camTImu() const { return cam_T_imu_; }
  const Eigen::Matrix4d& imuTCam() const { return imu_T_cam_; }

  /// Predicted observation [uL, vL, uR, vR] of p_world seen from the pose imu_T_world, and (when
  /// the pointers are given) the Jacobians with respect to the world-frame perturbation of the
  /// pose (world_T_imu = exp(eps^) world_T_imu_mean, eps = [rho; phi]; 4x6) and to p_world (4x3).
  /// Returns false when the point is not in front of the camera (depth <= min_depth).
  bool project(const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
               Eigen::Vector4d* z, Matrix46d* H_pose = nullptr, Matrix43d* H_landmark = nullptr,
               double min_depth = 1e-3) const;

  /// project() of the point turned by exp(angle^) about the IMU origin, IMU axes (a track that
  /// has drifted by `angle`; about the IMU rather than the camera, so that the turn cannot be
  /// told from a rotation of the pose): H_landmark as in project(), and H_angle (4x3) with
  /// respect to a left perturbation of the angle (exp(d^) exp(angle^)). angle = 0 gives
  /// project() exactly.
  bool projectTurned(const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
                     const Eigen::Vector3d& angle_imu, Eigen::Vector4d* z, Matrix43d* H_landmark,
                     Matrix43d* H_angle, double min_depth = 1e-3) const;

  /// Point in the left camera frame from (uL, v, uR) (v: the row, e.g. (vL + vR) / 2), and the
  /// 3x3 Jacobian of that point with respect to (uL, v, uR). Returns false when the disparity
  /// uL - uR is not positive.
  bool triangulate(double u_left, double v, double u_right, Eigen::Vector3d* p_cam,
                   Eigen::Matrix3d* J_p_cam_wrt_uvu = nullptr) const;

  /// True when (u, v) lies inside the image (always true when the image size is unknown).
  bool inImage(double u, double v, double margin_px = 0.0) const;

 private:
  StereoCalibration calibration_;
  Eigen::Matrix4d Ks_ = Eigen::Matrix4d::Zero();
  Eigen::Matrix4d cam_T_imu_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d imu_T_cam_ = Eigen::Matrix4d::Identity();
};

}  // namespace ekf_vislam
