#include "ekf_vislam/ros/twist_combiner_ros.h"

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/core/option_reader.h"
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/ros/ros_parameter_source.h"

#include <geometry_msgs/TwistWithCovarianceStamped.h>

#include <stdexcept>

namespace ekf_vislam {

namespace {

constexpr double kWarnPeriod = 5.0;  // s, throttle of the bad-input warnings
// Twists a subscriber in another process (the estimator run standalone) may fall behind before
// the oldest is dropped: 10 s at 200 Hz.
constexpr int kTwistQueue = 2000;

template <typename Options, typename Visitor>
void visitTwistCombinerRosOptions(Options& o, Visitor& v) {
  v.text("ros/imu_frame", o.imu_frame);
  v.integer("ros/queue_size", o.queue_size, Bound::kAtLeastOne);
  v.number("ros/tf_wait", o.tf_wait, Bound::kNonNegative);
  v.number("ros/diagnostic_period", o.diagnostic_period, Bound::kPositive);
  v.number("ros/time_jump_reset", o.time_jump_reset, Bound::kNonNegative);
}

constexpr auto kRosTable = [](auto& options, auto& visitor) {
  visitTwistCombinerRosOptions(options, visitor);
};

}  // namespace

bool parseTwistCombinerRosOptions(const ParameterSource& source, TwistCombinerRosOptions* options,
                                  std::string* error) {
  return readOptionTable(source, kRosTable, options, error,
                         [](const TwistCombinerRosOptions& o, OptionValidator* validator) {
                           if (o.imu_frame.empty()) {
                             validator->fail("'ros/imu_frame' must not be empty");
                           }
                         });
}

std::vector<OptionKeyList::Key> twistCombinerRosOptionKeys() {
  return optionTableKeys<TwistCombinerRosOptions>(kRosTable);
}

TwistCombinerRos::TwistCombinerRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                   const std::string& name)
    : nh_(nh), pnh_(pnh), name_(name) {
  RosParameterSource source(pnh_);
  std::string error;
  TwistCombinerOptions options;
  if (!parseTwistCombinerOptions(source, &options, &error) ||
      !parseTwistCombinerRosOptions(source, &ros_options_, &error)) {
    ROS_FATAL("%s: invalid parameters: %s", name_.c_str(), error.c_str());
    throw std::runtime_error("invalid parameters: " + error);
  }
  std::vector<std::string> known;
  appendKeyNames(twistCombinerOptionKeys(), &known);
  appendKeyNames(twistCombinerRosOptionKeys(), &known);
  const std::string unknown = describeUnknownKeys(unknownKeys(source, known), known);
  if (!unknown.empty()) {
    ROS_WARN("%s: %s: %s", name_.c_str(), source.describe().c_str(), unknown.c_str());
  }
  ROS_INFO("%s: options (from %s):\n%s", name_.c_str(), source.describe().c_str(),
           describeTwistCombinerOptions(options).c_str());
  combiner_ = std::make_unique<TwistCombiner>(options);
  time_jumps_ = TimeJumpDetector(ros_options_.time_jump_reset, 2);

  twist_pub_ = nh_.advertise<geometry_msgs::TwistWithCovarianceStamped>("imu/twist", kTwistQueue);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);
  imu_T_frame_ = FixedFrameTransforms(&tf_buffer_, ros_options_.imu_frame);
  diagnostics_ = std::make_unique<PeriodicDiagnostics>(nh_, pnh_, name_, "twist combiner",
                                                       ros_options_.diagnostic_period, this,
                                                       &TwistCombinerRos::produceDiagnostics);

  const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  imu_sub_ = nh_.subscribe("imu/data", ros_options_.queue_size, &TwistCombinerRos::imuCallback,
                           this, hints);
  odometry_sub_ = nh_.subscribe("wheel/odometry", ros_options_.queue_size,
                                &TwistCombinerRos::odometryCallback, this, hints);
  // A twist whose wheel sample is late goes on with the last one only after
  // combiner/max_velocity_wait of wall time too: this timer acts on it without new input.
  wait_timer_ = nh_.createWallTimer(ros::WallDuration(0.1), &TwistCombinerRos::waitTimer, this);
  ROS_INFO("%s: %s + %s -> %s (frame %s)", name_.c_str(), imu_sub_.getTopic().c_str(),
           odometry_sub_.getTopic().c_str(), twist_pub_.getTopic().c_str(),
           ros_options_.imu_frame.c_str());
}

void TwistCombinerRos::imuCallback(const sensor_msgs::Imu::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  restartIfTimeJumped(0, msg->header.stamp.toSec());
  imu_waiting_.push(msg);
  feedWaitingMessages();
}

void TwistCombinerRos::odometryCallback(const nav_msgs::Odometry::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  restartIfTimeJumped(1, msg->header.stamp.toSec());
  odometry_waiting_.push(msg);
  feedWaitingMessages();
}

void TwistCombinerRos::waitTimer(const ros::WallTimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  combiner_->releaseWaiting(steadyClockSeconds());
  publishReady();
}

void TwistCombinerRos::feedWaitingMessages() {
  feedWaiting(
      &imu_waiting_, [](const sensor_msgs::Imu& m) { return m.header.frame_id; },
      [this](const sensor_msgs::Imu& m, const Eigen::Isometry3d& imu_T_frame, std::string* why) {
        return combiner_->addAngularVelocity(
            ros_conversions::toAngularVelocitySample(m, imu_T_frame.linear()), why,
            steadyClockSeconds());
      });
  feedWaiting(
      &odometry_waiting_, [](const nav_msgs::Odometry& m) { return m.child_frame_id; },
      [this](const nav_msgs::Odometry& m, const Eigen::Isometry3d& imu_T_frame, std::string* why) {
        return combiner_->addLinearVelocity(ros_conversions::toLinearVelocitySample(m, imu_T_frame),
                                            why, steadyClockSeconds());
      });
  publishReady();
}

template <typename Msg, typename FrameOf, typename Feed>
void TwistCombinerRos::feedWaiting(TfWaitingQueue<Msg>* queue, const FrameOf& frame_of,
                                   const Feed& feed) {
  queue->drain(
      ros_options_.tf_wait, &imu_T_frame_, frame_of,
      [&](const Msg& msg, const Eigen::Isometry3d& imu_T_frame) {
        std::string why;
        if (!feed(msg, imu_T_frame, &why)) warnRefused(queue->topic(), why);
      },
      [&](const Msg&, const std::string& frame) {
        ROS_WARN_THROTTLE(kWarnPeriod,
                          "%s: %s in frame '%s': no tf to '%s' after %.1f s; sample dropped "
                          "(%lu so far)",
                          name_.c_str(), queue->topic(), frame.c_str(),
                          ros_options_.imu_frame.c_str(), ros_options_.tf_wait,
                          static_cast<unsigned long>(queue->droppedWithoutTf()));
      });
}

void TwistCombinerRos::restartIfTimeJumped(int stream, double stamp) {
  if (!time_jumps_.jumpedBack(stream, stamp)) return;
  ++time_jump_resets_;
  ROS_WARN(
      "%s: %s went back %.3f s in time (a bag played again?): the combiner starts again "
      "(%lu so far)",
      name_.c_str(), stream == 0 ? "imu/data" : "wheel/odometry", time_jumps_.lastJump(),
      static_cast<unsigned long>(time_jump_resets_));
  combiner_->reset();
  imu_waiting_.clear();
  odometry_waiting_.clear();
}

void TwistCombinerRos::publishReady() {
  for (const TwistData& twist : combiner_->takeReady()) {
    twist_pub_.publish(ros_conversions::toTwistWithCovarianceMsg(twist, ros_options_.imu_frame));
    ++twists_published_;
  }
}

void TwistCombinerRos::warnRefused(const char* what, const std::string& why) {
  ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s sample refused: %s (see /diagnostics)", name_.c_str(),
                    what, why.c_str());
}

void TwistCombinerRos::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const TwistCombinerCounters& c = combiner_->counters();
  const uint64_t refused = c.rejected_non_finite + c.rejected_not_increasing +
                           imu_waiting_.droppedWithoutTf() + odometry_waiting_.droppedWithoutTf() +
                           c.dropped_no_velocity;
  if (c.angular_received == 0 || c.linear_received == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   c.angular_received == 0 ? "no imu/data yet" : "no wheel/odometry yet");
  } else if (refused > refused_reported_ || c.velocity_held > held_reported_) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "input refused, dropped or held in the last period (see the counters)");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "combining");
  }
  status.add("imu_received", c.angular_received);
  status.add("odometry_received", c.linear_received);
  status.add("twists_published", twists_published_);
  status.add("velocity_held", c.velocity_held);
  status.add("dropped_no_velocity", c.dropped_no_velocity);
  status.add("rejected_non_finite", c.rejected_non_finite);
  status.add("rejected_not_increasing", c.rejected_not_increasing);
  status.add("imu_without_tf", imu_waiting_.droppedWithoutTf());
  status.add("odometry_without_tf", odometry_waiting_.droppedWithoutTf());
  status.add("waiting_for_tf", imu_waiting_.size() + odometry_waiting_.size());
  status.add("time_jump_resets", time_jump_resets_);
  refused_reported_ = refused;
  held_reported_ = c.velocity_held;
}

}  // namespace ekf_vislam
