#include "ekf_vislam/core/stereo_camera.h"

#include "ekf_vislam/core/se3.h"

#include <cmath>
#include <sstream>

namespace ekf_vislam {

std::string StereoCalibration::validate() const {
  std::ostringstream why;
  if (!std::isfinite(fx) || !std::isfinite(fy) || fx <= 0.0 || fy <= 0.0) {
    why << "focal length must be finite and positive (fx=" << fx << ", fy=" << fy << ")";
  } else if (!std::isfinite(cx) || !std::isfinite(cy)) {
    why << "principal point is not finite";
  } else if (!std::isfinite(baseline) || baseline <= 0.0) {
    why << "stereo baseline must be finite and positive (baseline=" << baseline << " m)";
  } else if (image_width < 0 || image_height < 0) {
    why << "image size must not be negative";
  } else if (!cam_T_imu.matrix().allFinite()) {
    why << "cam_T_imu is not finite";
  } else {
    const Eigen::Matrix3d R = cam_T_imu.linear();
    const double orth_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
    if (orth_error > 1e-3 || R.determinant() < 0.0) {
      why << "cam_T_imu rotation is not a rotation (|R^T R - I| = " << orth_error
          << ", det = " << R.determinant() << ")";
    }
  }
  return why.str();
}

StereoCamera::StereoCamera(const StereoCalibration& calibration) : calibration_(calibration) {
  const double fx = calibration.fx, fy = calibration.fy, cx = calibration.cx, cy = calibration.cy,
               b = calibration.baseline;
  Ks_ << fx, 0.0, cx, 0.0,   //
      0.0, fy, cy, 0.0,      //
      fx, 0.0, cx, -fx * b,  //
      0.0, fy, cy, 0.0;
  cam_T_imu_ = calibration.cam_T_imu.matrix();
  se3::normalizeRotation(&cam_T_imu_);
  imu_T_cam_ = se3::inverse(cam_T_imu_);
}

bool StereoCamera::project(const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
                           Eigen::Vector4d* z, Matrix46d* H_pose, Matrix43d* H_landmark,
                           double min_depth) const {
  const Eigen::Vector4d p_imu_h = imu_T_world * p_world.homogeneous();
  const Eigen::Vector4d q = cam_T_imu_ * p_imu_h;
  if (!(q(2) > min_depth)) return false;
  const double inv_z = 1.0 / q(2);
  *z = Ks_ * (q * inv_z);
  if (H_pose == nullptr && H_landmark == nullptr) return true;
  Eigen::Matrix4d dpi_dq = Eigen::Matrix4d::Zero();
  dpi_dq(0, 0) = inv_z;
  dpi_dq(1, 1) = inv_z;
  dpi_dq(0, 2) = -q(0) * inv_z * inv_z;
  dpi_dq(1, 2) = -q(1) * inv_z * inv_z;
  dpi_dq(3, 2) = -q(3) * inv_z * inv_z;
  dpi_dq(3, 3) = inv_z;
  // q = C U p_h with U = U_mean exp(-eps^): dq/deps = -C U p_h^odot.
  const Eigen::Matrix4d A = Ks_ * dpi_dq * cam_T_imu_ * imu_T_world;
  if (H_pose != nullptr) *H_pose = -A * se3::odot(p_world.homogeneous());
  if (H_landmark != nullptr) *H_landmark = A.leftCols<3>();
  return true;
}

bool StereoCamera::projectTurned(const Eigen::Matrix4d& imu_T_world, const Eigen::Vector3d& p_world,
                                 const Eigen::Vector3d& angle_imu, Eigen::Vector4d* z,
                                 Matrix43d* H_landmark, Matrix43d* H_angle,
                                 double min_depth) const {
  if (H_angle == nullptr && angle_imu.isZero(0.0)) {
    return project(imu_T_world, p_world, z, nullptr, H_landmark, min_depth);
  }
  // The turned point seen as a world point: p_seen = world_T_imu R_d imu_T_world p_world.
  const Eigen::Matrix3d R_iw = imu_T_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t_iw = imu_T_world.topRightCorner<3, 1>();
  const Eigen::Matrix3d R_d = se3::expSO3(angle_imu);
  const Eigen::Vector3d p_imu_seen = R_d * (R_iw * p_world + t_iw);
  const Eigen::Vector3d p_seen = R_iw.transpose() * (p_imu_seen - t_iw);
  Matrix43d H_seen;
  if (!project(imu_T_world, p_seen, z, nullptr, &H_seen, min_depth)) return false;
  const Matrix43d H_imu = H_seen * R_iw.transpose();  // d z / d p_imu_seen
  if (H_landmark != nullptr) *H_landmark = H_imu * R_d * R_iw;
  // exp((angle + d)^) = exp((J_l(angle) d)^) exp(angle^) to first order.
  if (H_angle != nullptr)
    *H_angle = -H_imu * se3::hat(p_imu_seen) * se3::leftJacobianSO3(angle_imu);
  return true;
}

bool StereoCamera::triangulate(double u_left, double v, double u_right, Eigen::Vector3d* p_cam,
                               Eigen::Matrix3d* J) const {
  const double d = u_left - u_right;
  if (!(d > 0.0)) return false;
  const double fx = calibration_.fx, fy = calibration_.fy, b = calibration_.baseline;
  const double du = u_left - calibration_.cx, dv = v - calibration_.cy;
  const double depth = fx * b / d;
  *p_cam << du * b / d, dv * fx * b / (fy * d), depth;
  if (J != nullptr) {
    const double d2 = d * d;
    // Columns: d/du_left, d/dv, d/du_right.
    *J << b / d - du * b / d2, 0.0, du * b / d2,                               //
        -dv * fx * b / (fy * d2), fx * b / (fy * d), dv * fx * b / (fy * d2),  //
        -fx * b / d2, 0.0, fx * b / d2;
  }
  return true;
}

bool StereoCamera::inImage(double u, double v, double margin_px) const {
  if (calibration_.image_width <= 0 || calibration_.image_height <= 0) return true;
  return u >= -margin_px && v >= -margin_px && u <= calibration_.image_width - 1 + margin_px &&
         v <= calibration_.image_height - 1 + margin_px;
}

Eigen::MatrixXd stereoObservationSelector(bool merge_rows) {
  if (!merge_rows) return Eigen::Matrix4d::Identity();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(3, 4);
  M(0, 0) = 1.0;
  M(1, 1) = 0.5;
  M(1, 3) = 0.5;
  M(2, 2) = 1.0;
  return M;
}

StereoCamera scaledStereoCamera(const StereoCalibration& nominal, double baseline_scale_error) {
  StereoCalibration scaled = nominal;
  scaled.baseline *= 1.0 + baseline_scale_error;
  return StereoCamera(scaled);
}

}  // namespace ekf_vislam
