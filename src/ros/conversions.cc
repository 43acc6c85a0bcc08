#include "ekf_vislam/ros/conversions.h"

#include "ekf_vislam/core/attached_frame.h"
#include "ekf_vislam/core/se3.h"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ekf_vislam {
namespace ros_conversions {

ros::Time toRosTime(double stamp) {
  ros::Time time;
  if (std::isfinite(stamp) && stamp >= 0.0 && stamp < 4294967295.0) time.fromSec(stamp);
  return time;
}

namespace {

bool allZero(const boost::array<double, 12>& p) {
  for (double value : p) {
    if (value != 0.0) return false;
  }
  return true;
}

}  // namespace

sensor_msgs::CameraInfo cameraInfoOfImage(const sensor_msgs::CameraInfo& full) {
  const sensor_msgs::RegionOfInterest& roi = full.roi;
  const bool has_roi = roi.x_offset != 0 || roi.y_offset != 0 ||
                       (roi.width != 0 && roi.width != full.width) ||
                       (roi.height != 0 && roi.height != full.height);
  const uint32_t binning_x = std::max<uint32_t>(1, full.binning_x);
  const uint32_t binning_y = std::max<uint32_t>(1, full.binning_y);
  if (!has_roi && binning_x == 1 && binning_y == 1) return full;
  sensor_msgs::CameraInfo info = full;
  if (has_roi) {
    info.K[2] -= roi.x_offset;
    info.K[5] -= roi.y_offset;
    info.P[2] -= roi.x_offset;
    info.P[6] -= roi.y_offset;
    info.width = roi.width != 0 ? roi.width : full.width - std::min(full.width, roi.x_offset);
    info.height = roi.height != 0 ? roi.height : full.height - std::min(full.height, roi.y_offset);
  }
  const double scale_x = 1.0 / binning_x, scale_y = 1.0 / binning_y;
  for (int i : {0, 2}) info.K[i] *= scale_x;
  for (int i : {4, 5}) info.K[i] *= scale_y;
  for (int i : {0, 2, 3}) info.P[i] *= scale_x;
  for (int i : {5, 6, 7}) info.P[i] *= scale_y;
  info.width /= binning_x;
  info.height /= binning_y;
  info.binning_x = info.binning_y = 0;
  info.roi = sensor_msgs::RegionOfInterest();
  return info;
}

std::string binningRoiError(const sensor_msgs::CameraInfo& full) {
  const sensor_msgs::RegionOfInterest& roi = full.roi;
  const uint64_t right_edge = uint64_t{roi.x_offset} + roi.width;
  const uint64_t bottom_edge = uint64_t{roi.y_offset} + roi.height;
  if (full.width != 0 && full.height != 0 &&
      (right_edge > full.width || bottom_edge > full.height || roi.x_offset >= full.width ||
       roi.y_offset >= full.height)) {
    std::ostringstream why;
    why << "roi (x " << roi.x_offset << ", y " << roi.y_offset << ", " << roi.width << "x"
        << roi.height << ") leaves the " << full.width << "x" << full.height << " image";
    return why.str();
  }
  const sensor_msgs::CameraInfo info = cameraInfoOfImage(full);
  if (full.width != 0 && full.height != 0 && (info.width == 0 || info.height == 0)) {
    std::ostringstream why;
    why << "binning " << full.binning_x << "x" << full.binning_y << " leaves no pixel of the "
        << (roi.width != 0 ? roi.width : full.width) << "x"
        << (roi.height != 0 ? roi.height : full.height) << " image";
    return why.str();
  }
  return "";
}

PinholeProjection projectionOf(const sensor_msgs::CameraInfo& full) {
  const sensor_msgs::CameraInfo info = cameraInfoOfImage(full);
  PinholeProjection projection;
  if (!allZero(info.P)) {
    projection = {info.P[0], info.P[5], info.P[2], info.P[6], info.P[3]};
  } else {
    projection = {info.K[0], info.K[4], info.K[2], info.K[5], 0.0};
  }
  projection.width = static_cast<int>(info.width);
  projection.height = static_cast<int>(info.height);
  return projection;
}

TwistData toTwistData(const geometry_msgs::TwistStamped& msg) {
  TwistData twist;
  twist.stamp = msg.header.stamp.toSec();
  twist.v_imu << msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z;
  twist.w_imu << msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z;
  return twist;
}

namespace {

TwistData fromTwistWithCovariance(double stamp, const geometry_msgs::TwistWithCovariance& msg,
                                  bool* covariance_invalid) {
  TwistData twist;
  twist.stamp = stamp;
  twist.v_imu << msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z;
  twist.w_imu << msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z;
  const Eigen::Matrix<double, 6, 6> covariance = fromCovarianceMsg(msg.covariance);
  const bool finite = covariance.allFinite();
  if (covariance_invalid != nullptr) *covariance_invalid = !finite;
  if (finite) twist.covariance = 0.5 * (covariance + covariance.transpose());
  return twist;
}

}  // namespace

TwistData toTwistData(const geometry_msgs::TwistWithCovarianceStamped& msg,
                      bool* covariance_invalid) {
  return fromTwistWithCovariance(msg.header.stamp.toSec(), msg.twist, covariance_invalid);
}

TwistData toTwistData(const nav_msgs::Odometry& msg, const Eigen::Isometry3d& imu_T_child,
                      bool* covariance_invalid) {
  const TwistData child =
      fromTwistWithCovariance(msg.header.stamp.toSec(), msg.twist, covariance_invalid);
  return moveTwist(se3::adjoint(imu_T_child.matrix()), child);
}

geometry_msgs::TwistWithCovarianceStamped toTwistWithCovarianceMsg(const TwistData& twist,
                                                                   const std::string& frame_id) {
  geometry_msgs::TwistWithCovarianceStamped msg;
  const geometry_msgs::TwistStamped plain = toTwistMsg(twist, frame_id);
  msg.header = plain.header;
  msg.twist.twist = plain.twist;
  toCovarianceMsg(twist.covariance, &msg.twist.covariance);
  return msg;
}

namespace {

/// One of an Imu's vectors and its row-major covariance, turned into the IMU frame.
struct ImuVector {
  Eigen::Vector3d value;
  Eigen::Matrix3d covariance;
};

ImuVector imuVector(const geometry_msgs::Vector3& v, const boost::array<double, 9>& covariance,
                    const Eigen::Matrix3d& R_imu_from_msg) {
  const Eigen::Matrix3d in_msg =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(covariance.data());
  return {R_imu_from_msg * Eigen::Vector3d(v.x, v.y, v.z),
          R_imu_from_msg * in_msg * R_imu_from_msg.transpose()};
}

}  // namespace

std::optional<AccelerometerData> toAccelerometerData(const sensor_msgs::Imu& msg,
                                                     const Eigen::Isometry3d& imu_T_msg) {
  if (msg.linear_acceleration_covariance[0] == -1.0) return std::nullopt;
  const ImuVector f =
      imuVector(msg.linear_acceleration, msg.linear_acceleration_covariance, imu_T_msg.linear());
  AccelerometerData sample;
  sample.stamp = msg.header.stamp.toSec();
  sample.f_imu = f.value;
  sample.p_accel_in_imu = imu_T_msg.translation();
  sample.covariance = f.covariance;
  return sample;
}

AngularVelocitySample toAngularVelocitySample(const sensor_msgs::Imu& msg,
                                              const Eigen::Matrix3d& R_imu_from_msg) {
  const ImuVector w =
      imuVector(msg.angular_velocity, msg.angular_velocity_covariance, R_imu_from_msg);
  AngularVelocitySample sample;
  sample.stamp = msg.header.stamp.toSec();
  sample.w_imu = w.value;
  if (msg.angular_velocity_covariance[0] != -1.0) sample.covariance = w.covariance;
  return sample;
}

LinearVelocitySample toLinearVelocitySample(const nav_msgs::Odometry& msg,
                                            const Eigen::Isometry3d& imu_T_child) {
  LinearVelocitySample sample;
  sample.stamp = msg.header.stamp.toSec();
  sample.v_base << msg.twist.twist.linear.x, msg.twist.twist.linear.y, msg.twist.twist.linear.z;
  sample.covariance = fromCovarianceMsg(msg.twist.covariance).topLeftCorner<3, 3>();
  sample.imu_T_base = imu_T_child;
  return sample;
}

geometry_msgs::TwistStamped toTwistMsg(const TwistData& twist, const std::string& frame_id) {
  geometry_msgs::TwistStamped msg;
  msg.header.stamp = toRosTime(twist.stamp);
  msg.header.frame_id = frame_id;
  msg.twist.linear.x = twist.v_imu.x();
  msg.twist.linear.y = twist.v_imu.y();
  msg.twist.linear.z = twist.v_imu.z();
  msg.twist.angular.x = twist.w_imu.x();
  msg.twist.angular.y = twist.w_imu.y();
  msg.twist.angular.z = twist.w_imu.z();
  return msg;
}

FeatureFrame toFeatureFrame(const ekf_vislam::StereoFeatureArray& msg) {
  FeatureFrame frame;
  frame.stamp = msg.header.stamp.toSec();
  frame.features.reserve(msg.features.size());
  for (const auto& f : msg.features) {
    StereoObservation feature;
    feature.id = f.id;
    feature.u_left = f.u_left;
    feature.v_left = f.v_left;
    feature.u_right = f.u_right;
    feature.v_right = f.v_right;
    frame.features.push_back(feature);
  }
  return frame;
}

ekf_vislam::StereoFeatureArray toFeatureArrayMsg(const FeatureFrame& frame,
                                                 const std::string& frame_id) {
  ekf_vislam::StereoFeatureArray msg;
  msg.header.stamp = toRosTime(frame.stamp);
  msg.header.frame_id = frame_id;
  msg.features.reserve(frame.features.size());
  for (const StereoObservation& feature : frame.features) {
    ekf_vislam::StereoFeature f;
    f.id = feature.id;
    f.u_left = static_cast<float>(feature.u_left);
    f.v_left = static_cast<float>(feature.v_left);
    f.u_right = static_cast<float>(feature.u_right);
    f.v_right = static_cast<float>(feature.v_right);
    msg.features.push_back(f);
  }
  return msg;
}

bool calibrationFromCameraInfo(const sensor_msgs::CameraInfo& left,
                               const sensor_msgs::CameraInfo& right, StereoCalibration* calibration,
                               std::string* error, double tolerance_px) {
  for (const sensor_msgs::CameraInfo* info : {&left, &right}) {
    const std::string why = binningRoiError(*info);
    if (!why.empty()) {
      *error = std::string(info == &left ? "left" : "right") + " camera_info: " + why;
      return false;
    }
  }
  return stereoIntrinsicsFromProjections(projectionOf(left), projectionOf(right), calibration,
                                         error, tolerance_px);
}

void cameraInfoFromCalibration(const StereoCalibration& calibration, sensor_msgs::CameraInfo* left,
                               sensor_msgs::CameraInfo* right) {
  for (sensor_msgs::CameraInfo* info : {left, right}) {
    *info = sensor_msgs::CameraInfo();
    info->width = static_cast<uint32_t>(std::max(0, calibration.image_width));
    info->height = static_cast<uint32_t>(std::max(0, calibration.image_height));
    info->distortion_model = "plumb_bob";
    info->D.assign(5, 0.0);
    info->K = {
        calibration.fx, 0.0, calibration.cx, 0.0, calibration.fy, calibration.cy, 0.0, 0.0, 1.0};
    info->R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    info->P = {calibration.fx,
               0.0,
               calibration.cx,
               0.0,
               0.0,
               calibration.fy,
               calibration.cy,
               0.0,
               0.0,
               0.0,
               1.0,
               0.0};
  }
  right->P[3] = -calibration.fx * calibration.baseline;
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& msg) {
  Eigen::Quaterniond q(msg.rotation.w, msg.rotation.x, msg.rotation.y, msg.rotation.z);
  const double norm = q.norm();
  if (norm == 0.0) {
    q = Eigen::Quaterniond::Identity();
  } else {
    q.coeffs() /= norm;  // NaN stays NaN
  }
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = q.toRotationMatrix();
  transform.translation() << msg.translation.x, msg.translation.y, msg.translation.z;
  return transform;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& transform) {
  return tf2::eigenToTransform(transform).transform;
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& transform) { return tf2::toMsg(transform); }

void toCovarianceMsg(const Eigen::Matrix<double, 6, 6>& covariance, boost::array<double, 36>* out) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) (*out)[6 * r + c] = covariance(r, c);
  }
}

Eigen::Matrix<double, 6, 6> fromCovarianceMsg(const boost::array<double, 36>& msg) {
  Eigen::Matrix<double, 6, 6> covariance;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) covariance(r, c) = msg[6 * r + c];
  }
  return covariance;
}

bool toOdometryMsg(double stamp, const std::string& world_frame, const std::string& imu_frame,
                   const Eigen::Isometry3d& world_T_imu,
                   const Eigen::Matrix<double, 6, 6>& pose_covariance_world,
                   const TwistData& twist_imu, const Eigen::Matrix<double, 6, 6>& twist_covariance,
                   nav_msgs::Odometry* out) {
  if (!std::isfinite(stamp) || !world_T_imu.matrix().allFinite() ||
      !pose_covariance_world.allFinite() || !twist_imu.v_imu.allFinite() ||
      !twist_imu.w_imu.allFinite() || !twist_covariance.allFinite()) {
    return false;
  }
  nav_msgs::Odometry msg;
  msg.header.stamp = toRosTime(stamp);
  msg.header.frame_id = world_frame;
  msg.child_frame_id = imu_frame;
  msg.pose.pose = toPoseMsg(world_T_imu);
  toCovarianceMsg(pose_covariance_world, &msg.pose.covariance);
  msg.twist.twist = toTwistMsg(twist_imu, imu_frame).twist;
  toCovarianceMsg(twist_covariance, &msg.twist.covariance);
  *out = msg;
  return true;
}

}  // namespace ros_conversions
}  // namespace ekf_vislam
