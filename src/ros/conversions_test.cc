// Unit tests of the ROS message conversions, the ROS-layer options and the shared runner (no
// roscore).
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/ros/bag_reader.h"
#include "ekf_vislam/ros/vislam_ros_options.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace ekf_vislam {
namespace {

namespace rc = ros_conversions;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

StereoCalibration kittiLike() {
  StereoCalibration c;
  c.fx = 707.0912;
  c.fy = 707.0912;
  c.cx = 601.8873;
  c.cy = 183.1104;
  c.baseline = 0.5379;
  c.image_width = 1241;
  c.image_height = 376;
  return c;
}

Eigen::Isometry3d somePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  T.translation() << 1.5, -2.25, 0.75;
  return T;
}

TEST(Conversions, TwistRoundTrip) {
  geometry_msgs::TwistStamped msg;
  msg.header.stamp = ros::Time(1317384506, 250000000);
  msg.header.frame_id = "imu";
  msg.twist.linear.x = 1.0;
  msg.twist.linear.y = -2.0;
  msg.twist.linear.z = 3.0;
  msg.twist.angular.x = 0.1;
  msg.twist.angular.y = -0.2;
  msg.twist.angular.z = 0.3;
  const TwistData twist = rc::toTwistData(msg);
  EXPECT_DOUBLE_EQ(twist.stamp, 1317384506.25);
  EXPECT_EQ(twist.v_imu, Eigen::Vector3d(1.0, -2.0, 3.0));
  EXPECT_EQ(twist.w_imu, Eigen::Vector3d(0.1, -0.2, 0.3));
  const geometry_msgs::TwistStamped back = rc::toTwistMsg(twist, "imu");
  EXPECT_EQ(back.header.stamp, msg.header.stamp);
  EXPECT_EQ(back.header.frame_id, "imu");
  EXPECT_EQ(back.twist.linear.y, -2.0);
  EXPECT_EQ(back.twist.angular.z, 0.3);
}

TEST(Conversions, TwistNaNPassesToTheEstimatorUnchanged) {
  geometry_msgs::TwistStamped msg;
  msg.twist.linear.x = kNaN;
  const TwistData twist = rc::toTwistData(msg);
  EXPECT_TRUE(std::isnan(twist.v_imu.x()));  // the estimator rejects and counts it
}

TEST(Conversions, TwistWithCovarianceTakesAFiniteNonZeroCovariance) {
  geometry_msgs::TwistWithCovarianceStamped msg;
  msg.header.stamp = ros::Time(100, 500000000);
  msg.twist.twist.linear.x = 3.0;
  msg.twist.twist.angular.z = -0.2;
  bool invalid = true;
  TwistData twist = rc::toTwistData(msg, &invalid);
  EXPECT_FALSE(invalid);
  EXPECT_FALSE(twist.hasCovariance());  // all zero: none given
  EXPECT_DOUBLE_EQ(twist.stamp, 100.5);
  EXPECT_DOUBLE_EQ(twist.v_imu.x(), 3.0);
  EXPECT_DOUBLE_EQ(twist.w_imu.z(), -0.2);
  for (int i = 0; i < 6; ++i) msg.twist.covariance[7 * i] = 0.01 * (i + 1);
  msg.twist.covariance[1] = msg.twist.covariance[6] = 0.002;
  twist = rc::toTwistData(msg, &invalid);
  ASSERT_TRUE(twist.hasCovariance());
  EXPECT_DOUBLE_EQ(twist.covariance(5, 5), 0.06);
  EXPECT_DOUBLE_EQ(twist.covariance(0, 1), 0.002);
  msg.twist.covariance[14] = std::numeric_limits<double>::quiet_NaN();
  twist = rc::toTwistData(msg, &invalid);
  EXPECT_TRUE(invalid);
  EXPECT_FALSE(twist.hasCovariance());  // the configured noise is used
}

TEST(Conversions, ImuAndWheelOdometryBecomeTheCombinerSamples) {
  sensor_msgs::Imu imu;
  imu.header.stamp = ros::Time(7, 500000000);
  imu.angular_velocity.x = 0.1;
  imu.angular_velocity.y = -0.2;
  imu.angular_velocity.z = 0.3;
  imu.angular_velocity_covariance[0] = -1.0;  // unknown
  const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0.0, 0.0, M_PI / 2));
  AngularVelocitySample gyro = rc::toAngularVelocitySample(imu, R);
  EXPECT_DOUBLE_EQ(gyro.stamp, 7.5);
  EXPECT_LT((gyro.w_imu - R * Eigen::Vector3d(0.1, -0.2, 0.3)).norm(), 1e-15);
  EXPECT_TRUE(gyro.covariance.isZero(0.0));
  imu.angular_velocity_covariance = {1e-4, 0, 0, 0, 2e-4, 0, 0, 0, 3e-4};
  gyro = rc::toAngularVelocitySample(imu, R);
  // Rotated a quarter turn about z: x and y variances swap.
  EXPECT_NEAR(gyro.covariance(0, 0), 2e-4, 1e-18);
  EXPECT_NEAR(gyro.covariance(1, 1), 1e-4, 1e-18);
  EXPECT_NEAR(gyro.covariance(2, 2), 3e-4, 1e-18);

  nav_msgs::Odometry odometry;
  odometry.header.stamp = ros::Time(8, 0);
  odometry.child_frame_id = "base_link";
  odometry.twist.twist.linear.x = 4.0;
  odometry.twist.covariance[0] = 0.01;
  odometry.twist.covariance[35] = 9.0;  // the angular part is not the wheel sample's
  Eigen::Isometry3d imu_T_base = Eigen::Isometry3d::Identity();
  imu_T_base.translation() = Eigen::Vector3d(-1.0, 0.0, -0.5);
  const LinearVelocitySample wheel = rc::toLinearVelocitySample(odometry, imu_T_base);
  EXPECT_DOUBLE_EQ(wheel.stamp, 8.0);
  EXPECT_EQ(wheel.v_base, Eigen::Vector3d(4.0, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(wheel.covariance(0, 0), 0.01);
  EXPECT_DOUBLE_EQ(wheel.covariance.sum(), 0.01);
  EXPECT_TRUE(wheel.imu_T_base.isApprox(imu_T_base));

  TwistData twist;
  twist.stamp = 9.25;
  twist.v_imu = Eigen::Vector3d(1, 2, 3);
  twist.covariance(4, 4) = 0.5;
  const geometry_msgs::TwistWithCovarianceStamped msg = rc::toTwistWithCovarianceMsg(twist, "imu");
  EXPECT_EQ(msg.header.frame_id, "imu");
  EXPECT_DOUBLE_EQ(msg.header.stamp.toSec(), 9.25);
  EXPECT_DOUBLE_EQ(msg.twist.twist.linear.z, 3.0);
  EXPECT_DOUBLE_EQ(msg.twist.covariance[4 * 6 + 4], 0.5);
}

TEST(Conversions, ImuAccelerometerIsRotatedIntoTheImuFrameOrMissing) {
  sensor_msgs::Imu imu;
  imu.header.stamp = ros::Time(3, 250000000);
  imu.linear_acceleration.x = 0.5;
  imu.linear_acceleration.y = -0.1;
  imu.linear_acceleration.z = 9.8;
  imu.linear_acceleration_covariance = {4e-4, 0, 0, 0, 1e-4, 0, 0, 0, 9e-4};
  const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0.0, 0.0, M_PI / 2));
  Eigen::Isometry3d imu_T_frame = Eigen::Isometry3d::Identity();
  imu_T_frame.linear() = R;
  imu_T_frame.translation() = Eigen::Vector3d(0.3, -0.2, 0.1);  // the lever arm, kept
  std::optional<AccelerometerData> sample = rc::toAccelerometerData(imu, imu_T_frame);
  ASSERT_TRUE(sample.has_value());
  EXPECT_DOUBLE_EQ(sample->stamp, 3.25);
  EXPECT_LT((sample->f_imu - R * Eigen::Vector3d(0.5, -0.1, 9.8)).norm(), 1e-14);
  EXPECT_EQ(sample->p_accel_in_imu, imu_T_frame.translation());
  // A quarter turn about z: x and y variances swap.
  EXPECT_NEAR(sample->covariance(0, 0), 1e-4, 1e-18);
  EXPECT_NEAR(sample->covariance(1, 1), 4e-4, 1e-18);
  imu.linear_acceleration_covariance = {};  // unknown: estimated online
  sample = rc::toAccelerometerData(imu, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(sample.has_value());
  EXPECT_FALSE(sample->hasCovariance());
  imu.linear_acceleration_covariance[0] = -1.0;  // the Imu convention: no accelerometer
  EXPECT_FALSE(rc::toAccelerometerData(imu, Eigen::Isometry3d::Identity()).has_value());
}

TEST(Conversions, OdometryTwistInAnotherFrameMatchesRigidBodyMotion) {
  // The child frame C sits at p in the IMU frame I, rotated by R. A rigid body moving with the
  // child's twist: the IMU's twist from finite differences of world_T_imu = world_T_child
  // child_T_imu must equal the conversion's.
  Eigen::Isometry3d imu_T_child = Eigen::Isometry3d::Identity();
  imu_T_child.linear() = se3::expSO3(Eigen::Vector3d(0.1, -0.3, 1.2));
  imu_T_child.translation() = Eigen::Vector3d(0.8, -0.4, 1.5);
  nav_msgs::Odometry msg;
  msg.header.stamp = ros::Time(5, 0);
  msg.child_frame_id = "base_link";
  const Eigen::Vector3d v_child(2.0, 0.3, -0.1), w_child(0.05, -0.2, 0.4);
  msg.twist.twist.linear.x = v_child.x();
  msg.twist.twist.linear.y = v_child.y();
  msg.twist.twist.linear.z = v_child.z();
  msg.twist.twist.angular.x = w_child.x();
  msg.twist.twist.angular.y = w_child.y();
  msg.twist.twist.angular.z = w_child.z();
  for (int i = 0; i < 6; ++i) msg.twist.covariance[7 * i] = i < 3 ? 0.04 : 0.0004;
  const TwistData imu = rc::toTwistData(msg, imu_T_child);
  Vector6d xi_child;  // element-wise: GCC 12 warns (-Warray-bounds) on a vectorized 3-vector copy
  for (int i = 0; i < 3; ++i) {
    xi_child(i) = v_child(i);
    xi_child(3 + i) = w_child(i);
  }
  // Conjugating an exponential is exact (T^-1 exp(h xi^) T = exp(h (Ad xi)^)), so any step works.
  const double h = 0.5;
  const Eigen::Matrix4d child_T_imu = imu_T_child.inverse().matrix();
  // world_T_child(h) = exp(h xi^) (world = the child at t = 0).
  const Eigen::Matrix4d world_T_imu_0 = child_T_imu;
  const Eigen::Matrix4d world_T_imu_h = se3::exp(h * xi_child) * child_T_imu;
  const Eigen::Matrix4d delta = world_T_imu_0.inverse() * world_T_imu_h;  // exp(h u_imu^)
  const Vector6d u_fd = se3::log(delta) / h;
  EXPECT_LT((imu.v_imu - u_fd.head<3>()).norm(), 1e-9);
  EXPECT_LT((imu.w_imu - u_fd.tail<3>()).norm(), 1e-9);
  // The covariance through the same linear map: a finite-difference Jacobian.
  Eigen::Matrix<double, 6, 6> J;
  for (int i = 0; i < 6; ++i) {
    Vector6d step = Vector6d::Zero();
    step(i) = 1e-3;
    const Eigen::Matrix4d moved = se3::exp(h * (xi_child + step)) * child_T_imu;
    J.col(i) = (se3::log(world_T_imu_0.inverse() * moved) / h - u_fd) / 1e-3;
  }
  const Eigen::Matrix<double, 6, 6> expected =
      J * rc::fromCovarianceMsg(msg.twist.covariance) * J.transpose();
  EXPECT_LT((imu.covariance - expected).norm(), 1e-8 * expected.norm());
  // The same frame: unchanged.
  const TwistData same = rc::toTwistData(msg, Eigen::Isometry3d::Identity());
  EXPECT_LT((same.v_imu - v_child).norm(), 1e-15);
}

TEST(Conversions, FeaturesRoundTrip) {
  ekf_vislam::StereoFeatureArray msg;
  msg.header.stamp = ros::Time(100, 500000000);
  msg.header.frame_id = "camera_left";
  for (uint32_t id : {7u, 3u, 4000000000u}) {
    ekf_vislam::StereoFeature f;
    f.id = id;
    f.u_left = 100.5f + id % 10;
    f.v_left = 50.25f;
    f.u_right = 90.5f;
    f.v_right = 50.75f;
    msg.features.push_back(f);
  }
  const FeatureFrame frame = rc::toFeatureFrame(msg);
  EXPECT_DOUBLE_EQ(frame.stamp, 100.5);
  ASSERT_EQ(frame.features.size(), 3u);
  EXPECT_EQ(frame.features[0].id, 7u);
  EXPECT_EQ(frame.features[1].id, 3u);  // message order kept
  EXPECT_EQ(frame.features[2].id, 4000000000u);
  EXPECT_DOUBLE_EQ(frame.features[0].u_left, 107.5);
  EXPECT_DOUBLE_EQ(frame.features[1].v_right, 50.75);
  const ekf_vislam::StereoFeatureArray back = rc::toFeatureArrayMsg(frame, "camera_left");
  EXPECT_EQ(back.header.stamp, msg.header.stamp);
  ASSERT_EQ(back.features.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(back.features[i], msg.features[i]);
}

TEST(Conversions, EmptyFeatureFrame) {
  ekf_vislam::StereoFeatureArray msg;
  EXPECT_TRUE(rc::toFeatureFrame(msg).features.empty());
}

TEST(Conversions, CameraInfoPairGivesCalibration) {
  sensor_msgs::CameraInfo left, right;
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  EXPECT_NEAR(right.P[3], -707.0912 * 0.5379, 1e-9);
  StereoCalibration c;
  c.cam_T_imu = somePose();
  std::string error;
  ASSERT_TRUE(rc::calibrationFromCameraInfo(left, right, &c, &error)) << error;
  EXPECT_DOUBLE_EQ(c.fx, 707.0912);
  EXPECT_DOUBLE_EQ(c.fy, 707.0912);
  EXPECT_DOUBLE_EQ(c.cx, 601.8873);
  EXPECT_DOUBLE_EQ(c.cy, 183.1104);
  EXPECT_NEAR(c.baseline, 0.5379, 1e-12);
  EXPECT_EQ(c.image_width, 1241);
  EXPECT_EQ(c.image_height, 376);
  EXPECT_TRUE(c.cam_T_imu.isApprox(somePose()));  // extrinsic untouched
  c.cam_T_imu = Eigen::Isometry3d::Identity();
  EXPECT_EQ(c.validate(), "");
}

TEST(Conversions, CameraInfoFallsBackToKWithoutP) {
  sensor_msgs::CameraInfo left, right;
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  left.P.fill(0.0);
  StereoCalibration c;
  std::string error;
  ASSERT_TRUE(rc::calibrationFromCameraInfo(left, right, &c, &error)) << error;
  EXPECT_DOUBLE_EQ(c.fx, 707.0912);
  EXPECT_DOUBLE_EQ(c.cy, 183.1104);
}

// A driver's binning and region of interest: the calibration is the full sensor's, the image is
// the ROI binned. The image's projection follows image_geometry: principal point moved by the
// ROI's offset, then x and y scaled by the binning; the baseline (P[3] / fx) is unchanged.
TEST(Conversions, BinningAndRoiGiveTheImagesProjection) {
  sensor_msgs::CameraInfo left, right;
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  for (sensor_msgs::CameraInfo* info : {&left, &right}) {
    info->binning_x = 2;
    info->binning_y = 2;
    info->roi.x_offset = 100;
    info->roi.y_offset = 40;
    info->roi.width = 800;
    info->roi.height = 300;
  }
  const PinholeProjection p = rc::projectionOf(left);
  EXPECT_DOUBLE_EQ(p.fx, 707.0912 / 2);
  EXPECT_DOUBLE_EQ(p.fy, 707.0912 / 2);
  EXPECT_DOUBLE_EQ(p.cx, (601.8873 - 100) / 2);
  EXPECT_DOUBLE_EQ(p.cy, (183.1104 - 40) / 2);
  EXPECT_EQ(p.width, 400);
  EXPECT_EQ(p.height, 150);
  const sensor_msgs::CameraInfo of_image = rc::cameraInfoOfImage(left);
  EXPECT_DOUBLE_EQ(of_image.K[2], (601.8873 - 100) / 2);  // K alike (the raw camera's)
  EXPECT_DOUBLE_EQ(of_image.K[5], (183.1104 - 40) / 2);
  EXPECT_EQ(of_image.binning_x, 0u);
  EXPECT_EQ(of_image.roi.width, 0u);
  StereoCalibration c;
  std::string error;
  ASSERT_TRUE(rc::calibrationFromCameraInfo(left, right, &c, &error)) << error;
  EXPECT_NEAR(c.baseline, 0.5379, 1e-12);
  EXPECT_EQ(c.image_width, 400);

  // Binning alone (x only), and an ROI whose width and height are 0: from its offset to the end.
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  left.binning_x = 4;
  EXPECT_DOUBLE_EQ(rc::projectionOf(left).fx, 707.0912 / 4);
  EXPECT_DOUBLE_EQ(rc::projectionOf(left).fy, 707.0912);
  EXPECT_EQ(rc::projectionOf(left).width, 1241 / 4);
  EXPECT_EQ(rc::projectionOf(left).height, 376);
  left.binning_x = 1;
  left.roi.x_offset = 41;
  EXPECT_EQ(rc::projectionOf(left).width, 1200);
  EXPECT_DOUBLE_EQ(rc::projectionOf(left).cx, 601.8873 - 41);

  // An ROI beyond the image, or a binning that leaves no pixel: refused with what is wrong.
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  right.roi.x_offset = 1000;
  right.roi.width = 300;
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_EQ(error, "right camera_info: roi (x 1000, y 0, 300x0) leaves the 1241x376 image");
  right.roi = sensor_msgs::RegionOfInterest();
  left.binning_y = 400;
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_EQ(error, "left camera_info: binning 0x400 leaves no pixel of the 1241x376 image");

  // Without either (binning 0 or 1, an ROI all zero or the full image): unchanged.
  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  left.binning_x = 1;
  left.roi.width = 1241;
  left.roi.height = 376;
  EXPECT_EQ(rc::cameraInfoOfImage(left), left);
}

TEST(Conversions, BadCameraInfoIsRefusedWithAMessage) {
  sensor_msgs::CameraInfo left, right;
  StereoCalibration c;
  std::string error;

  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  left.P[0] = 0.0;
  left.K[0] = 0.0;
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_NE(error.find("focal"), std::string::npos) << error;

  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  right.P[2] += 3.0;  // cx differs: not a rectified pair
  error.clear();
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_NE(error.find("disagree"), std::string::npos) << error;

  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  right.P[3] = 0.0;  // no baseline (e.g. the left info twice)
  error.clear();
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_NE(error.find("baseline"), std::string::npos) << error;

  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  right.P[3] = +380.0;  // left and right swapped
  error.clear();
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_NE(error.find("baseline"), std::string::npos) << error;

  rc::cameraInfoFromCalibration(kittiLike(), &left, &right);
  left.P[2] = kNaN;
  right.P[2] = kNaN;
  error.clear();
  EXPECT_FALSE(rc::calibrationFromCameraInfo(left, right, &c, &error));
  EXPECT_FALSE(error.empty());
  EXPECT_EQ(c.fx, 0.0);  // untouched on failure
}

TEST(Conversions, TransformRoundTrip) {
  const Eigen::Isometry3d T = somePose();
  const geometry_msgs::Transform msg = rc::toTransformMsg(T);
  EXPECT_DOUBLE_EQ(msg.translation.x, 1.5);
  const Eigen::Isometry3d back = rc::toIsometry(msg);
  EXPECT_TRUE(back.matrix().isApprox(T.matrix(), 1e-12));
  const geometry_msgs::Pose pose = rc::toPoseMsg(T);
  EXPECT_DOUBLE_EQ(pose.orientation.w, msg.rotation.w);
  EXPECT_DOUBLE_EQ(pose.position.z, 0.75);
}

TEST(Conversions, TransformNormalizesTheQuaternion) {
  geometry_msgs::Transform msg;
  msg.rotation.w = 2.0;  // not unit
  msg.translation.y = 1.0;
  Eigen::Isometry3d T = rc::toIsometry(msg);
  EXPECT_TRUE(T.linear().isApprox(Eigen::Matrix3d::Identity()));
  msg.rotation.w = 0.0;  // all zero: identity
  T = rc::toIsometry(msg);
  EXPECT_TRUE(T.linear().isApprox(Eigen::Matrix3d::Identity()));
  msg.rotation.x = kNaN;  // NaN stays visible, so calibration validation refuses it
  T = rc::toIsometry(msg);
  StereoCalibration c = kittiLike();
  c.cam_T_imu = T;
  EXPECT_NE(c.validate(), "");
}

TEST(Conversions, CovarianceLayoutIsRowMajor) {
  Eigen::Matrix<double, 6, 6> cov;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) cov(r, c) = 10 * r + c;
  }
  boost::array<double, 36> msg;
  rc::toCovarianceMsg(cov, &msg);
  EXPECT_EQ(msg[0], 0.0);
  EXPECT_EQ(msg[1], 1.0);    // (0, 1)
  EXPECT_EQ(msg[6], 10.0);   // (1, 0)
  EXPECT_EQ(msg[35], 55.0);  // (5, 5)
  EXPECT_EQ(msg[6 * 3 + 5], 35.0);
  EXPECT_EQ(rc::fromCovarianceMsg(msg), cov);
}

TEST(Conversions, Odometry) {
  Eigen::Matrix<double, 6, 6> pose_cov = Eigen::Matrix<double, 6, 6>::Identity();
  pose_cov(0, 0) = 4.0;   // x variance
  pose_cov(5, 5) = 0.01;  // yaw variance
  pose_cov(0, 5) = pose_cov(5, 0) = 0.05;
  Eigen::Matrix<double, 6, 6> twist_cov = 0.5 * Eigen::Matrix<double, 6, 6>::Identity();
  TwistData twist;
  twist.v_imu << 8.0, 0.1, 0.0;
  twist.w_imu << 0.0, 0.0, 0.2;
  nav_msgs::Odometry odom;
  ASSERT_TRUE(
      rc::toOdometryMsg(12.5, "world", "imu", somePose(), pose_cov, twist, twist_cov, &odom));
  EXPECT_EQ(odom.header.frame_id, "world");
  EXPECT_EQ(odom.child_frame_id, "imu");
  EXPECT_EQ(odom.header.stamp, ros::Time(12, 500000000));
  EXPECT_DOUBLE_EQ(odom.pose.pose.position.x, 1.5);
  EXPECT_EQ(odom.pose.covariance[0], 4.0);
  EXPECT_EQ(odom.pose.covariance[35], 0.01);
  EXPECT_EQ(odom.pose.covariance[5], 0.05);
  EXPECT_EQ(odom.pose.covariance[30], 0.05);
  EXPECT_EQ(odom.twist.twist.linear.x, 8.0);
  EXPECT_EQ(odom.twist.twist.angular.z, 0.2);
  EXPECT_EQ(odom.twist.covariance[7], 0.5);
  const Eigen::Quaterniond q(somePose().linear());
  EXPECT_NEAR(std::abs(q.dot(
                  Eigen::Quaterniond(odom.pose.pose.orientation.w, odom.pose.pose.orientation.x,
                                     odom.pose.pose.orientation.y, odom.pose.pose.orientation.z))),
              1.0, 1e-12);
}

TEST(Conversions, OdometryNeverCarriesNaN) {
  const Eigen::Matrix<double, 6, 6> I = Eigen::Matrix<double, 6, 6>::Identity();
  TwistData twist;
  nav_msgs::Odometry odom;
  odom.header.frame_id = "untouched";
  Eigen::Isometry3d bad_pose = somePose();
  bad_pose.translation().x() = kNaN;
  EXPECT_FALSE(rc::toOdometryMsg(1.0, "world", "imu", bad_pose, I, twist, I, &odom));
  Eigen::Matrix<double, 6, 6> bad_cov = I;
  bad_cov(2, 3) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(rc::toOdometryMsg(1.0, "world", "imu", somePose(), bad_cov, twist, I, &odom));
  EXPECT_FALSE(rc::toOdometryMsg(1.0, "world", "imu", somePose(), I, twist, bad_cov, &odom));
  TwistData bad_twist;
  bad_twist.w_imu.y() = kNaN;
  EXPECT_FALSE(rc::toOdometryMsg(1.0, "world", "imu", somePose(), I, bad_twist, I, &odom));
  EXPECT_FALSE(rc::toOdometryMsg(kNaN, "world", "imu", somePose(), I, twist, I, &odom));
  EXPECT_EQ(odom.header.frame_id, "untouched");
}

TEST(Conversions, StaticTransformLookupFollowsChains) {
  geometry_msgs::TransformStamped a, b;
  a.header.frame_id = "imu";
  a.child_frame_id = "base_camera";
  a.transform = rc::toTransformMsg(somePose());
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translation() << 0.0, 0.0, 0.3;
  b.header.frame_id = "base_camera";
  b.child_frame_id = "camera_left";
  b.transform = rc::toTransformMsg(offset);
  Eigen::Isometry3d imu_T_cam;
  std::string error;
  ASSERT_TRUE(lookupStaticTransform({a, b}, "imu", "camera_left", &imu_T_cam, &error)) << error;
  EXPECT_TRUE(imu_T_cam.matrix().isApprox((somePose() * offset).matrix(), 1e-12));
  EXPECT_FALSE(lookupStaticTransform({a}, "imu", "camera_left", &imu_T_cam, &error));
  EXPECT_NE(error.find("camera_left"), std::string::npos) << error;
}

TEST(RosOptions, DefaultsAndParsing) {
  VislamRosOptions defaults;
  EXPECT_EQ(defaults.validate(), "");
  const YamlParameterSource source = YamlParameterSource::fromString(
      "ros:\n"
      "  world_frame: map\n"
      "  imu_frame: base_imu\n"
      "  publish_tf: false\n"
      "  landmark_marker_rate: 5\n"
      "  covariance_ellipsoids: true\n"
      "  sequencer_max_delay: 0.25\n"
      "  output_dir: /tmp/out\n"
      "  calibration:\n"
      "    fx: 700\n    fy: 701\n    cx: 600\n    cy: 180\n    baseline: 0.54\n"
      "    cam_T_imu: \"0 -1 0 0.1  0 0 -1 0.2  1 0 0 0.3  0 0 0 1\"\n");
  ASSERT_TRUE(source.ok()) << source.error();
  VislamRosOptions o;
  std::string error;
  ASSERT_TRUE(parseVislamRosOptions(source, &o, &error)) << error;
  EXPECT_EQ(o.world_frame, "map");
  EXPECT_EQ(o.imu_frame, "base_imu");
  EXPECT_FALSE(o.publish_tf);
  EXPECT_EQ(o.landmark_marker_rate, 5.0);
  EXPECT_TRUE(o.covariance_ellipsoids);
  EXPECT_EQ(o.sequencer_max_delay, 0.25);
  EXPECT_EQ(o.output_dir, "/tmp/out");
  EXPECT_TRUE(o.calibration.has_intrinsics);
  EXPECT_EQ(o.calibration.calibration.fy, 701.0);
  EXPECT_EQ(describeOptions(o).find("world_frame=map") != std::string::npos, true);
  ASSERT_TRUE(o.calibration.has_extrinsic);
  EXPECT_EQ(o.calibration.calibration.cam_T_imu.translation(), Eigen::Vector3d(0.1, 0.2, 0.3));
}

TEST(RosOptions, StringFormOfCamTImu) {
  const YamlParameterSource source = YamlParameterSource::fromString(
      "ros:\n  calibration:\n    cam_T_imu: \"0 -1 0 0.1  0 0 -1 0.2  1 0 0 0.3  0 0 0 1\"\n");
  VislamRosOptions o;
  std::string error;
  ASSERT_TRUE(parseVislamRosOptions(source, &o, &error)) << error;
  ASSERT_TRUE(o.calibration.has_extrinsic);
  EXPECT_FALSE(o.calibration.has_intrinsics);
  EXPECT_EQ(o.calibration.calibration.cam_T_imu.translation(), Eigen::Vector3d(0.1, 0.2, 0.3));
  StereoCalibration target = kittiLike();
  o.calibration.applyTo(&target);
  EXPECT_EQ(target.fx, kittiLike().fx);
  EXPECT_EQ(target.validate(), "");
}

TEST(RosOptions, ShippedConfigHasNoUnknownKeyAndATypoIsNamed) {
  const YamlParameterSource shipped(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(shipped.ok()) << shipped.error();
  EXPECT_EQ(unknownEstimatorKeys(shipped), "");
  EXPECT_EQ(unknownEstimatorKeys(YamlParameterSource::fromString(
                "ros: {publish_tff: false, calibration: {fx: 700}}\nvehicle: {tilt_sigma: 0}\n")),
            "unknown key ignored: ros/publish_tff (ros/publish_tf?)");
}

TEST(RosOptions, ShippedConfigHasEveryKeyAndEveryBoundedKeyIsChecked) {
  const YamlParameterSource shipped(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(shipped.ok()) << shipped.error();
  VislamRosOptions parsed;
  std::string error;
  ASSERT_TRUE(parseVislamRosOptions(shipped, &parsed, &error)) << error;
  EXPECT_EQ(describeOptions(parsed), describeOptions(VislamRosOptions()));
  int bounded = 0;
  for (const OptionKeyList::Key& key : vislamRosOptionKeys()) {
    EXPECT_TRUE(shipped.has(key.name)) << key.name << " is not documented in config/default.yaml";
    if (key.bound == Bound::kAny) continue;
    ++bounded;
    std::ostringstream yaml;
    yaml << "ros:\n  " << key.name.substr(4) << ": " << valueOutside(key.bound) << "\n";
    VislamRosOptions o;
    EXPECT_FALSE(parseVislamRosOptions(YamlParameterSource::fromString(yaml.str()), &o, &error))
        << yaml.str();
    EXPECT_NE(error.find(key.name), std::string::npos) << error;
  }
  EXPECT_GE(bounded, 12);
}

TEST(RosOptions, ErrorsNameTheKey) {
  VislamRosOptions o;
  std::string error;
  EXPECT_FALSE(parseVislamRosOptions(YamlParameterSource::fromString("ros:\n  publish_tf: maybe\n"),
                                     &o, &error));
  EXPECT_NE(error.find("ros/publish_tf"), std::string::npos) << error;
  EXPECT_FALSE(parseVislamRosOptions(
      YamlParameterSource::fromString("ros:\n  calibration:\n    fx: 700\n"), &o, &error));
  EXPECT_NE(error.find("ros/calibration"), std::string::npos) << error;
  EXPECT_FALSE(parseVislamRosOptions(
      YamlParameterSource::fromString("ros:\n  calibration:\n    cam_T_imu: \"1 0 0\"\n"), &o,
      &error));
  EXPECT_NE(error.find("16 numbers"), std::string::npos) << error;
  EXPECT_FALSE(parseVislamRosOptions(YamlParameterSource::fromString("ros:\n  twist_type: imu\n"),
                                     &o, &error));
  EXPECT_NE(error.find("twist_stamped | twist_with_covariance | odometry"), std::string::npos)
      << error;
  EXPECT_FALSE(parseVislamRosOptions(YamlParameterSource::fromString("ros:\n  world_frame: imu\n"),
                                     &o, &error));
  EXPECT_EQ(o.world_frame, "world");  // untouched on failure
}

}  // namespace
}  // namespace ekf_vislam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
