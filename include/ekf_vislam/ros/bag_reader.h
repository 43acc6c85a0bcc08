// Reads the inputs of the offline runner from a bag with the C++ rosbag API (no roscore):
// calibration messages (camera_info pair, /tf_static) and the twist/feature stream in bag order,
// converted with the same functions as the nodelet (ros/conversions.h).
#pragma once

#include "ekf_vislam/core/measurement_sequencer.h"
#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/core/twist_combiner.h"
#include "ekf_vislam/ros/tf_waiting_queue.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace rosbag {
class Bag;
class MessageInstance;
}  // namespace rosbag

namespace ekf_vislam {

struct BagTopics {
  std::string twist = "/imu/twist";
  std::string features = "/stereo/features";
  std::string left_info = "/stereo/left/camera_info";
  std::string right_info = "/stereo/right/camera_info";
  std::string tf_static = "/tf_static";
  /// sensor_msgs/Imu: its accelerometer (gravity/), and its gyro with the wheel odometry when
  /// the twist is combined
  std::string imu_data = "/imu/data";
  std::string wheel_odometry = "/wheel/odometry";  ///< with the gyro: a combined twist
};

/// What the bag says about the calibration (first message of each camera_info topic).
struct BagCalibrationData {
  bool has_left_info = false;
  bool has_right_info = false;
  sensor_msgs::CameraInfo left_info;
  sensor_msgs::CameraInfo right_info;
  /// header.frame_id of the first feature message (left camera_info's when there is none).
  std::string camera_frame;
  std::vector<geometry_msgs::TransformStamped> static_transforms;
  /// camera_info messages whose projection or image size differs from the first of their camera:
  /// ignored (the calibration comes from the first pair), as the node ignores them.
  uint64_t camera_info_changed = 0;
};

class BagReader {
 public:
  BagReader();
  ~BagReader();

  /// Opens the bag; false with a one-line message when it cannot be read.
  bool open(const std::string& path, const BagTopics& topics, std::string* error);
  /// Number of messages on a topic (0 when the bag has none).
  uint32_t messageCount(const std::string& topic) const;
  /// Data type of a topic ("" when absent).
  std::string dataType(const std::string& topic) const;

  bool readCalibrationData(BagCalibrationData* data, std::string* error);

  /// For twists given as nav_msgs/Odometry in another child frame: the IMU frame and the static
  /// transforms that lead there.
  void setTwistFrames(const std::string& imu_frame,
                      const std::vector<geometry_msgs::TransformStamped>& static_transforms);

  /// Makes the twist from the gyro (topics.imu_data) and the wheel odometry
  /// (topics.wheel_odometry) with a TwistCombiner, as twist_combiner_node does live (time jumps
  /// restart it alike), instead of reading topics.twist. Call after setTwistFrames.
  void useTwistCombiner(const TwistCombinerOptions& options, double time_jump_reset);
  const TwistCombiner* twistCombiner() const { return combiner_.get(); }

  /// Also reads the accelerometer of topics.imu_data (samples whose Imu says it has none are
  /// skipped), as the estimator node does live. Call after setTwistFrames.
  void useAccelerometer() { accelerometer_ = true; }

  /// Every twist (TwistStamped, TwistWithCovarianceStamped or Odometry), accelerometer sample
  /// (useAccelerometer) and feature message in
  /// bag order, converted; `fraction` in [0, 1] is the progress through the bag. False (with a
  /// message) on a message of another type, or an odometry frame with no transform to the IMU.
  using Callback = std::function<void(Measurement&& measurement, double fraction)>;
  bool forEachMeasurement(const Callback& callback, std::string* error);

 private:
  bool convertTwist(const rosbag::MessageInstance& m, TwistData* twist, std::string* error);
  /// An Imu message: its accelerometer sample (useAccelerometer, when it has one) and its gyro
  /// sample to the combiner (useTwistCombiner), then the twists the combiner completes.
  bool readImu(const rosbag::MessageInstance& m, const Callback& callback, double fraction,
               std::string* error);
  /// A wheel odometry message to the combiner, then the twists it completes.
  bool readWheelOdometry(const rosbag::MessageInstance& m, const Callback& callback,
                         double fraction, std::string* error);
  /// imu_frame <- frame from the static transforms (identity for the IMU frame itself).
  bool imuTFrame(const std::string& frame, Eigen::Isometry3d* imu_T_frame, std::string* error);

  std::unique_ptr<rosbag::Bag> bag_;
  BagTopics topics_;
  std::unique_ptr<tf2::BufferCore> static_tf_;        ///< the bag's static transforms
  FixedFrameTransforms imu_T_frame_{nullptr, "imu"};  ///< imu_frame <- input frames, cached
  std::unique_ptr<TwistCombiner> combiner_;
  bool accelerometer_ = false;
  TimeJumpDetector combiner_time_jumps_{0.0, 2};
};

/// Transform of camera_frame in imu_frame (imu_T_cam) from static transforms, chains allowed
/// (tf2::BufferCore lookup, as the nodelet's tf2_ros::Buffer). False with a message otherwise.
bool lookupStaticTransform(const std::vector<geometry_msgs::TransformStamped>& transforms,
                           const std::string& target_frame, const std::string& source_frame,
                           Eigen::Isometry3d* target_T_source, std::string* error);

}  // namespace ekf_vislam
