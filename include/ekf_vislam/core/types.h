// Plain measurement and calibration structs fed to the estimator core. No ROS.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace ekf_vislam {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Body-frame twist of the IMU at time `stamp` (seconds).
struct TwistData {
  double stamp = 0.0;
  Eigen::Vector3d v_imu = Eigen::Vector3d::Zero();  ///< linear velocity, m/s, IMU frame
  Eigen::Vector3d w_imu = Eigen::Vector3d::Zero();  ///< angular velocity, rad/s, IMU frame
  /// Covariance of one sample of [v; w] (the message's own, e.g. TwistWithCovarianceStamped);
  /// all zero: none given (the configured noise is used).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool hasCovariance() const { return !covariance.isZero(0.0); }
};

/// One accelerometer sample in the IMU frame: the mean specific force (m/s^2; at rest and level
/// +g along up) over the period ending at `stamp`, as an IMU integrates it.
struct AccelerometerData {
  double stamp = 0.0;
  Eigen::Vector3d f_imu = Eigen::Vector3d::Zero();
  /// m, where the accelerometer sits in the IMU frame (its lever arm; zero: at the origin).
  Eigen::Vector3d p_accel_in_imu = Eigen::Vector3d::Zero();
  /// Covariance of one sample (the message's own); zero = unknown (estimated online).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool hasCovariance() const { return !covariance.isZero(0.0); }
};

/// One tracked feature in a rectified stereo pair (pixels); the core side of the
/// ekf_vislam/StereoFeature message.
struct StereoObservation {
  uint32_t id = 0;
  double u_left = 0.0;
  double v_left = 0.0;
  double u_right = 0.0;
  double v_right = 0.0;
};

/// All features observed in one stereo frame (stamp = image time, seconds).
struct FeatureFrame {
  double stamp = 0.0;
  std::vector<StereoObservation> features;
};

/// Rectified stereo intrinsics plus the IMU -> left camera optical frame extrinsic.
struct StereoCalibration {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double baseline = 0.0;  ///< metres, > 0 (right camera at +baseline along the left camera's x)
  int image_width = 0;    ///< pixels; 0 = unknown (no out-of-image check)
  int image_height = 0;   ///< pixels; 0 = unknown
  /// Maps IMU-frame points into the left camera optical frame (z forward, x right, y down).
  Eigen::Isometry3d cam_T_imu = Eigen::Isometry3d::Identity();

  /// Empty when usable; otherwise one line saying what is wrong (finite, positive focal lengths
  /// and baseline, rotation orthonormal with determinant +1, ...).
  std::string validate() const;
};

/// A pose with its time stamp (seconds).
struct StampedPose {
  double stamp = 0.0;
  Eigen::Isometry3d world_T_imu = Eigen::Isometry3d::Identity();
};

/// One landmark of the map: the current estimate for a tracked (active) landmark, the final one
/// (kept after marginalization) for a landmark whose track ended.
struct LandmarkEstimate {
  uint32_t id = 0;  ///< track id (an id seen again after its track ended is a new landmark)
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of p_world, m^2
  uint32_t observations = 0;  ///< observations used (initialization + updates)
  bool active = false;        ///< still in the filter state
  double first_stamp = 0.0;
  double last_stamp = 0.0;

  /// Its estimate has used two observations or more (a restart of its track starts it again from
  /// one). The map the package outputs (landmarks.csv, the markers' map) holds confirmed
  /// landmarks only: one observation confirms nothing, and a landmark started from a wrong stereo
  /// match is a confident wrong point.
  bool confirmed() const { return observations >= 2; }
};

/// How many of `landmarks` are confirmed (the map's size).
inline size_t landmarksInMap(const std::vector<LandmarkEstimate>& landmarks) {
  size_t count = 0;
  for (const LandmarkEstimate& l : landmarks) count += l.confirmed() ? 1 : 0;
  return count;
}

}  // namespace ekf_vislam
