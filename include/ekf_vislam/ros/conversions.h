// Message <-> core struct conversions: the only place where ROS messages meet the estimator types.
// Pure functions (no node handle, no clock), unit-tested in src/ros/conversions_test.cc.
#pragma once

#include <ekf_vislam/StereoFeature.h>
#include <ekf_vislam/StereoFeatureArray.h>
#include "ekf_vislam/core/calibration_builder.h"
#include "ekf_vislam/core/twist_combiner.h"
#include "ekf_vislam/core/types.h"

#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Imu.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <boost/array.hpp>

#include <optional>
#include <string>

namespace ekf_vislam {
namespace ros_conversions {

/// Seconds -> ros::Time; a stamp ROS cannot represent (non-finite, negative, past 2106) gives 0.
ros::Time toRosTime(double stamp);

/// Twist message -> core twist (stamp in seconds). Non-finite values pass through unchanged:
/// the estimator rejects and counts them.
TwistData toTwistData(const geometry_msgs::TwistStamped& msg);
geometry_msgs::TwistStamped toTwistMsg(const TwistData& twist, const std::string& frame_id);
/// TwistWithCovarianceStamped -> core twist. The covariance is taken when it is finite and not
/// all zero; a non-finite one is dropped (the configured noise is used) and *covariance_invalid
/// is set.
TwistData toTwistData(const geometry_msgs::TwistWithCovarianceStamped& msg,
                      bool* covariance_invalid = nullptr);
/// Odometry -> the twist of the IMU. The message's twist is that of child_frame_id, expressed in
/// it; imu_T_child is the fixed transform from that frame to the IMU frame (identity when they
/// are the same). With R, p its rotation and translation: w_imu = R w_child and
/// v_imu = R v_child + p^ R w_child (rigid body; p is the child origin in the IMU frame), and the
/// covariance goes through J = [[R, p^ R], [0, R]]. Covariance handling as above.
TwistData toTwistData(const nav_msgs::Odometry& msg, const Eigen::Isometry3d& imu_T_child,
                      bool* covariance_invalid = nullptr);

/// The combined twist as TwistWithCovarianceStamped (all-zero covariance when it has none).
geometry_msgs::TwistWithCovarianceStamped toTwistWithCovarianceMsg(const TwistData& twist,
                                                                   const std::string& frame_id);
/// sensor_msgs/Imu -> the accelerometer sample (linear_acceleration, the specific force) rotated
/// into the IMU frame by imu_T_msg, whose translation is the accelerometer's lever arm (the
/// gravity update takes it into account); nothing when linear_acceleration_covariance[0] = -1
/// (no data, the Imu convention). An all-zero covariance is unknown (estimated online).
std::optional<AccelerometerData> toAccelerometerData(const sensor_msgs::Imu& msg,
                                                     const Eigen::Isometry3d& imu_T_msg);

/// sensor_msgs/Imu -> the gyro sample of TwistCombiner, rotated into the IMU frame by
/// R_imu_from_msg (identity when the message is in it). angular_velocity_covariance[0] = -1
/// (unknown, the Imu convention) or all zero gives no covariance.
AngularVelocitySample toAngularVelocitySample(const sensor_msgs::Imu& msg,
                                              const Eigen::Matrix3d& R_imu_from_msg);
/// nav_msgs/Odometry -> the wheel sample of TwistCombiner: the linear velocity of
/// child_frame_id in its own axes, its 3x3 covariance, and where that frame is (imu_T_child).
LinearVelocitySample toLinearVelocitySample(const nav_msgs::Odometry& msg,
                                            const Eigen::Isometry3d& imu_T_child);

/// Feature message -> core frame (stamp in seconds, features in message order).
FeatureFrame toFeatureFrame(const ekf_vislam::StereoFeatureArray& msg);
ekf_vislam::StereoFeatureArray toFeatureArrayMsg(const FeatureFrame& frame,
                                                 const std::string& frame_id);

/// The camera_info of the image a driver sends with binning (binning_x / binning_y above 1) or a
/// region of interest (roi), whose K, P and size are the full sensor's: the principal points moved
/// by the ROI's offset, then K's and P's x (y) row scaled by 1 / binning_x (binning_y), the size
/// the ROI's (the full size from its offset on when its width / height is 0) divided by the
/// binning; the result has neither. As image_geometry's PinholeCameraModel reads a camera_info (a
/// rectified image with an ROI is the same crop of the full rectified image). Unchanged without.
sensor_msgs::CameraInfo cameraInfoOfImage(const sensor_msgs::CameraInfo& info);
/// Why a camera_info's ROI and binning give no image ("" when they do): an ROI that leaves the
/// full image (when the camera_info gives its size), or no pixel left after the binning.
std::string binningRoiError(const sensor_msgs::CameraInfo& info);
/// A camera_info's rectified projection: P (K when P is all zero) and the image size, of the image
/// as sent (cameraInfoOfImage: binning and ROI applied).
PinholeProjection projectionOf(const sensor_msgs::CameraInfo& info);
/// Rectified stereo intrinsics from the left/right camera_info pair
/// (stereoIntrinsicsFromProjections of their projections; binningRoiError refuses first). Leaves
/// calibration->cam_T_imu unchanged (it comes from tf).
bool calibrationFromCameraInfo(const sensor_msgs::CameraInfo& left,
                               const sensor_msgs::CameraInfo& right, StereoCalibration* calibration,
                               std::string* error, double tolerance_px = 1e-3);
/// The camera_info pair describing `calibration` (for tests and tools).
void cameraInfoFromCalibration(const StereoCalibration& calibration, sensor_msgs::CameraInfo* left,
                               sensor_msgs::CameraInfo* right);

/// geometry_msgs/Transform <-> Eigen. The quaternion is normalized (an all-zero quaternion gives
/// the identity rotation; a non-finite one a non-finite matrix, which StereoCalibration::validate
/// rejects).
Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& msg);
geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& transform);
geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& transform);

/// 6x6 matrix <-> the row-major float64[36] of ROS covariance fields.
void toCovarianceMsg(const Eigen::Matrix<double, 6, 6>& covariance, boost::array<double, 36>* out);
Eigen::Matrix<double, 6, 6> fromCovarianceMsg(const boost::array<double, 36>& msg);

/// Odometry of the IMU: header.frame_id = world_frame, child_frame_id = imu_frame, pose =
/// world_T_imu with pose_covariance_world (ROS order x y z rx ry rz, world axes), twist = the IMU
/// twist in the child frame with its covariance ([v; w]). Returns false and leaves *out
/// untouched when any input is not finite (never publish NaN).
bool toOdometryMsg(double stamp, const std::string& world_frame, const std::string& imu_frame,
                   const Eigen::Isometry3d& world_T_imu,
                   const Eigen::Matrix<double, 6, 6>& pose_covariance_world,
                   const TwistData& twist_imu, const Eigen::Matrix<double, 6, 6>& twist_covariance,
                   nav_msgs::Odometry* out);

}  // namespace ros_conversions
}  // namespace ekf_vislam
