#include "ekf_vislam/core/calibration_builder.h"

#include <cmath>
#include <sstream>

namespace ekf_vislam {

bool sameProjection(const PinholeProjection& a, const PinholeProjection& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.tx == b.tx &&
         a.width == b.width && a.height == b.height;
}

bool stereoIntrinsicsFromProjections(const PinholeProjection& l, const PinholeProjection& r,
                                     StereoCalibration* calibration, std::string* error,
                                     double tolerance_px) {
  std::ostringstream why;
  auto finitePositive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!finitePositive(l.fx) || !finitePositive(l.fy) || !finitePositive(r.fx) ||
      !finitePositive(r.fy)) {
    why << "camera_info focal lengths must be finite and positive (left fx=" << l.fx
        << " fy=" << l.fy << ", right fx=" << r.fx << " fy=" << r.fy << ")";
  } else if (!std::isfinite(l.cx) || !std::isfinite(l.cy) || !std::isfinite(r.cx) ||
             !std::isfinite(r.cy) || !std::isfinite(r.tx)) {
    why << "camera_info principal point or P[0,3] is not finite";
  } else if (std::abs(l.fx - r.fx) > tolerance_px || std::abs(l.fy - r.fy) > tolerance_px ||
             std::abs(l.cx - r.cx) > tolerance_px || std::abs(l.cy - r.cy) > tolerance_px) {
    why << "left and right camera_info intrinsics disagree (left fx fy cx cy = " << l.fx << " "
        << l.fy << " " << l.cx << " " << l.cy << ", right = " << r.fx << " " << r.fy << " " << r.cx
        << " " << r.cy << "): the stereo pair must be rectified";
  } else if (!(-r.tx / r.fx > 0.0)) {
    why << "stereo baseline -P_right[0,3]/fx_right must be positive (P_right[0,3]=" << r.tx << ")";
  }
  if (!why.str().empty()) {
    if (error) *error = why.str();
    return false;
  }
  calibration->fx = l.fx;
  calibration->fy = l.fy;
  calibration->cx = l.cx;
  calibration->cy = l.cy;
  calibration->baseline = -r.tx / r.fx;
  calibration->image_width = l.width;
  calibration->image_height = l.height;
  return true;
}

void CalibrationOverride::applyTo(StereoCalibration* target) const {
  if (has_intrinsics) {
    target->fx = calibration.fx;
    target->fy = calibration.fy;
    target->cx = calibration.cx;
    target->cy = calibration.cy;
    target->baseline = calibration.baseline;
    if (calibration.image_width > 0) target->image_width = calibration.image_width;
    if (calibration.image_height > 0) target->image_height = calibration.image_height;
  }
  if (has_extrinsic) target->cam_T_imu = calibration.cam_T_imu;
}

bool CalibrationBuilder::setProjections(const PinholeProjection& left,
                                        const PinholeProjection& right, std::string* error) {
  StereoCalibration intrinsics;
  if (!stereoIntrinsicsFromProjections(left, right, &intrinsics, &projections_error_)) {
    intrinsics_.reset();
    if (error) *error = projections_error_;
    return false;
  }
  projections_error_.clear();
  intrinsics_ = intrinsics;
  return true;
}

bool CalibrationBuilder::build(StereoCalibration* calibration, std::string* why) const {
  auto refuse = [why](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  StereoCalibration built;
  if (needsProjections()) {
    if (!intrinsics_) {
      return refuse(projections_error_.empty() ? "no camera_info (left and right)"
                                               : "camera_info refused: " + projections_error_);
    }
    built = *intrinsics_;
  }
  if (needsImuTCam()) {
    if (!imu_T_cam_) return refuse("no transform from the IMU frame to the camera frame");
    built.cam_T_imu = imu_T_cam_->inverse();
  }
  override_.applyTo(&built);
  const std::string invalid = built.validate();
  if (!invalid.empty()) return refuse("calibration refused: " + invalid);
  *calibration = built;
  return true;
}

}  // namespace ekf_vislam
