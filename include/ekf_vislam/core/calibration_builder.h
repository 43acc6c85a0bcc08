// Builds the stereo calibration from its sources, the same way for the nodelet and the offline
// runner: the rectified left/right projections (camera_info), the IMU-to-camera transform (tf)
// and the optional ros/calibration override that replaces either. No ROS: the ROS layer converts
// camera_info into PinholeProjection and looks the transform up.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Geometry>

#include <optional>
#include <string>

namespace ekf_vislam {

/// One rectified camera's projection as camera_info gives it: P (K when P is all zero).
struct PinholeProjection {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double tx = 0.0;  ///< P[0,3]: -fx * baseline for the right camera, 0 for the left
  int width = 0;    ///< px (0 = unknown)
  int height = 0;
};

/// True when a and b hold the same fx, fy, cx, cy, tx and image size: a camera_info unlike the
/// one the calibration was built from is counted and ignored (node and vislam_offline alike).
bool sameProjection(const PinholeProjection& a, const PinholeProjection& b);

/// Rectified stereo intrinsics: fx, fy, cx, cy and the image size from the left projection,
/// baseline b = -tx_right / fx_right. Refuses (false, *error says why) non-finite or
/// non-positive focal lengths, left/right intrinsics that disagree by more than tolerance_px and
/// b <= 0. Leaves calibration->cam_T_imu unchanged.
bool stereoIntrinsicsFromProjections(const PinholeProjection& left, const PinholeProjection& right,
                                     StereoCalibration* calibration, std::string* error,
                                     double tolerance_px = 1e-3);

/// Calibration given as parameters instead of camera_info / tf (ros/calibration/...).
struct CalibrationOverride {
  /// ros/calibration/{fx, fy, cx, cy, baseline} (all five or none; image_width/height optional).
  bool has_intrinsics = false;
  /// ros/calibration/cam_T_imu: 16 numbers, row-major.
  bool has_extrinsic = false;
  StereoCalibration calibration;  ///< the values given (intrinsics and/or cam_T_imu)

  /// Replaces what the override gives in a calibration built from the messages.
  void applyTo(StereoCalibration* calibration) const;
};

/// Collects the pieces the override does not give, then assembles and validates the calibration.
class CalibrationBuilder {
 public:
  explicit CalibrationBuilder(CalibrationOverride calibration_override)
      : override_(std::move(calibration_override)) {}

  bool needsProjections() const { return !override_.has_intrinsics; }
  bool needsImuTCam() const { return !override_.has_extrinsic; }

  /// The left/right projections; false (and *error) when they are refused.
  bool setProjections(const PinholeProjection& left, const PinholeProjection& right,
                      std::string* error);
  /// The camera frame's pose in the IMU frame (tf imu_frame -> camera frame).
  void setImuTCam(const Eigen::Isometry3d& imu_T_cam) { imu_T_cam_ = imu_T_cam; }
  /// Every needed piece is there (build() can then only fail on invalid values).
  bool complete() const {
    return (!needsProjections() || intrinsics_) && (!needsImuTCam() || imu_T_cam_);
  }

  /// The calibration, once every needed piece is there and it validates; otherwise false and
  /// *why says what is missing or wrong.
  bool build(StereoCalibration* calibration, std::string* why) const;

 private:
  CalibrationOverride override_;
  std::optional<StereoCalibration> intrinsics_;  ///< from the projections
  std::string projections_error_;                ///< why the last projections were refused
  std::optional<Eigen::Isometry3d> imu_T_cam_;
};

}  // namespace ekf_vislam
