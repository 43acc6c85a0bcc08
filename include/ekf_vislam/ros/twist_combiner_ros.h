// The ROS side of TwistCombiner, shared by TwistCombinerNodelet and twist_combiner_node: a gyro
// (sensor_msgs/Imu on imu/data) and a wheel odometry (nav_msgs/Odometry on wheel/odometry) in,
// the IMU's body twist (geometry_msgs/TwistWithCovarianceStamped on imu/twist, frame
// ros/imu_frame) out, for the estimator with ros/twist_type twist_with_covariance. Frames other
// than ros/imu_frame are taken to it through tf (the odometry's child frame with its lever arm).
// Bad input is warned about (throttled) and counted in /diagnostics.
#pragma once

#include "ekf_vislam/core/option_table.h"
#include "ekf_vislam/core/parameter_source.h"
#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/core/twist_combiner.h"

#include "ekf_vislam/ros/periodic_diagnostics.h"
#include "ekf_vislam/ros/tf_waiting_queue.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Geometry>

#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace ekf_vislam {

struct TwistCombinerRosOptions {
  std::string imu_frame = "imu";   ///< frame of the output twist (the estimator's ros/imu_frame)
  int queue_size = 2000;           ///< subscriber queues (nothing dropped at 10x playback)
  double tf_wait = 1.0;            ///< s (message and wall time) a sample waits for its frame's tf
  double diagnostic_period = 1.0;  ///< s
  double time_jump_reset = 1.0;    ///< s back in time that restarts the combiner (0: never)
};

bool parseTwistCombinerRosOptions(const ParameterSource& source, TwistCombinerRosOptions* options,
                                  std::string* error);
std::vector<OptionKeyList::Key> twistCombinerRosOptionKeys();

class TwistCombinerRos {
 public:
  /// Reads the options from `pnh` (throws std::runtime_error when invalid).
  TwistCombinerRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name);

 private:
  void imuCallback(const sensor_msgs::Imu::ConstPtr& msg);
  void odometryCallback(const nav_msgs::Odometry::ConstPtr& msg);
  /// Feeds both inputs' waiting messages whose frames tf knows to the combiner, then publishes.
  void feedWaitingMessages();
  /// feed(msg, imu_T_frame, &why) for each waiting message of `queue` in order, while tf knows
  /// frame_of(msg); one tf still lacks after ros/tf_wait s of message time and of wall time is
  /// dropped (warned).
  template <typename Msg, typename FrameOf, typename Feed>
  void feedWaiting(TfWaitingQueue<Msg>* queue, const FrameOf& frame_of, const Feed& feed);
  void restartIfTimeJumped(int stream, double stamp);
  void publishReady();
  /// Every 0.1 s of wall time: publishes the twists whose wait for the wheel stream is over.
  void waitTimer(const ros::WallTimerEvent&);
  void warnRefused(const char* what, const std::string& why);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, pnh_;
  std::string name_;
  TwistCombinerRosOptions ros_options_;
  std::unique_ptr<TwistCombiner> combiner_;
  ros::Subscriber imu_sub_, odometry_sub_;
  ros::Publisher twist_pub_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<PeriodicDiagnostics> diagnostics_;
  ros::WallTimer wait_timer_;

  std::mutex mutex_;
  FixedFrameTransforms imu_T_frame_;
  TfWaitingQueue<sensor_msgs::Imu> imu_waiting_{"imu/data"};
  TfWaitingQueue<nav_msgs::Odometry> odometry_waiting_{"wheel/odometry"};
  TimeJumpDetector time_jumps_{0.0, 2};  ///< gyro 0, wheel 1
  uint64_t time_jump_resets_ = 0;
  uint64_t twists_published_ = 0;
  uint64_t refused_reported_ = 0, held_reported_ = 0;  ///< at the last diagnostics period
};

}  // namespace ekf_vislam
