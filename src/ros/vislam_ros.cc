#include "ekf_vislam/ros/vislam_ros.h"

#include "ekf_vislam/core/attached_frame.h"
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/ros/heap_allocation.h"
#include "ekf_vislam/ros/landmark_markers.h"
#include "ekf_vislam/ros/ros_parameter_source.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <variant>

namespace ekf_vislam {

VislamRos::VislamRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name)
    : nh_(nh), pnh_(pnh), name_(name) {
  keepLargeAllocationsOnHeap();
  loadOptions();
  runner_ = std::make_unique<EstimatorRunner>(
      options_,
      MeasurementSequencer::Options{ros_options_.sequencer_max_delay,
                                    static_cast<size_t>(ros_options_.sequencer_max_buffered)});
  runner_->enablePreview(true);        // twist-rate odometry
  runner_->enableWallClockWait(true);  // a late stream is waited for in wall time too
  runner_->enableTimeJumpReset(ros_options_.time_jump_reset);
  if (ros_options_.calibration.has_intrinsics && ros_options_.calibration.has_extrinsic) {
    tryCalibrate();
  }

  path_.header.frame_id = ros_options_.world_frame;
  const ros::WallTime now = ros::WallTime::now();
  last_input_ = last_twist_ = last_features_ = last_diag_ = now;

  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);
  imu_T_frame_ = FixedFrameTransforms(&tf_buffer_, ros_options_.imu_frame);
  advertiseOutputs();
  subscribeInputs();
  startTimersAndServices();
  ROS_INFO("%s: listening on %s and %s%s%s, publishing %s", name_.c_str(),
           twist_sub_.getTopic().c_str(), features_sub_.getTopic().c_str(),
           imu_sub_ ? " (accelerometer: " : "", imu_sub_ ? (imu_sub_.getTopic() + ")").c_str() : "",
           odometry_pub_.getTopic().c_str());
}

void VislamRos::loadOptions() {
  RosParameterSource source(pnh_);
  std::string error;
  if (!parseVislamOptions(source, &options_, &error) ||
      !parseVislamRosOptions(source, &ros_options_, &error)) {
    ROS_FATAL("%s: invalid parameters: %s", name_.c_str(), error.c_str());
    throw std::runtime_error("invalid parameters: " + error);
  }
  const std::string why = options_.validate();
  if (!why.empty()) {
    ROS_FATAL("%s: invalid parameters: %s", name_.c_str(), why.c_str());
    throw std::runtime_error("invalid parameters: " + why);
  }
  unknown_parameters_ = unknownEstimatorKeys(source);
  if (!unknown_parameters_.empty()) {
    ROS_WARN("%s: %s: %s", name_.c_str(), source.describe().c_str(), unknown_parameters_.c_str());
  }
  ROS_INFO("%s: effective options (from %s):\n%s\n%s", name_.c_str(), source.describe().c_str(),
           describeOptions(options_).c_str(), describeOptions(ros_options_).c_str());
}

void VislamRos::advertiseOutputs() {
  odometry_pub_ = pnh_.advertise<nav_msgs::Odometry>("odometry", 100);
  odometry_update_pub_ = pnh_.advertise<nav_msgs::Odometry>("odometry_update", 100);
  path_pub_ = pnh_.advertise<nav_msgs::Path>("path", 1, true);
  landmarks_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("landmarks", 1, true);
}

void VislamRos::subscribeInputs() {
  const int queue = ros_options_.queue_size;
  const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  if (ros_options_.twist_type == TwistMessageType::kOdometry) {
    twist_sub_ = nh_.subscribe("imu/twist", queue, &VislamRos::odometryTwistCallback, this, hints);
  } else if (ros_options_.twist_type == TwistMessageType::kTwistWithCovariance) {
    twist_sub_ =
        nh_.subscribe("imu/twist", queue, &VislamRos::twistWithCovarianceCallback, this, hints);
  } else {
    twist_sub_ = nh_.subscribe("imu/twist", queue, &VislamRos::twistCallback, this, hints);
  }
  features_sub_ =
      nh_.subscribe("stereo/features", queue, &VislamRos::featuresCallback, this, hints);
  if (usesAccelerometer(options_)) {
    imu_sub_ = nh_.subscribe("imu/data", queue, &VislamRos::imuCallback, this, hints);
  }
  left_info_sub_ = nh_.subscribe("stereo/left/camera_info", 10, &VislamRos::leftInfoCallback, this);
  right_info_sub_ =
      nh_.subscribe("stereo/right/camera_info", 10, &VislamRos::rightInfoCallback, this);
}

void VislamRos::startTimersAndServices() {
  // Releases what the calibration wait held back once it is over, and what waited for a stopped
  // stream for ros/sequencer_max_delay of wall time (the sequencer waits in both clocks).
  wait_timer_ = nh_.createWallTimer(ros::WallDuration(0.1), &VislamRos::waitTimer, this);
  if (ros_options_.landmark_marker_rate > 0.0 || ros_options_.path_rate > 0.0) {
    const double rate = std::max(ros_options_.landmark_marker_rate, ros_options_.path_rate);
    landmark_timer_ =
        nh_.createWallTimer(ros::WallDuration(1.0 / rate), &VislamRos::visualizationTimer, this);
  }
  diagnostics_ = std::make_unique<PeriodicDiagnostics>(nh_, pnh_, name_, "estimator",
                                                       ros_options_.diagnostic_period, this,
                                                       &VislamRos::produceDiagnostics);
  // Last, so that a client seeing the services knows the subscriptions are registered.
  reset_srv_ = pnh_.advertiseService("reset", &VislamRos::resetService, this);
  save_srv_ = pnh_.advertiseService("save", &VislamRos::saveService, this);
}

VislamRos::~VislamRos() { shutdown(); }

void VislamRos::shutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_) return;
  shut_down_ = true;
  publishing_ = false;
  wait_timer_.stop();
  landmark_timer_.stop();
  diagnostics_->stop();
  twist_sub_.shutdown();
  features_sub_.shutdown();
  imu_sub_.shutdown();
  left_info_sub_.shutdown();
  right_info_sub_.shutdown();
  tryCalibrate();
  calibration_wait_over_ = true;
  runner_->flush([this](const EstimatorRunner::Processed& p) { onProcessed(p); });
  if (!ros_options_.output_dir.empty()) {
    std::string message;
    if (saveLocked(&message)) {
      ROS_INFO("%s: %s", name_.c_str(), message.c_str());
    } else {
      ROS_ERROR("%s: %s", name_.c_str(), message.c_str());
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Inputs
// ---------------------------------------------------------------------------------------------

void VislamRos::twistCallback(const geometry_msgs::TwistStamped::ConstPtr& msg) {
  warnIfNotImuFrame(msg->header.frame_id);
  std::lock_guard<std::mutex> lock(mutex_);
  onTwist(ros_conversions::toTwistData(*msg), false);
}

void VislamRos::twistWithCovarianceCallback(
    const geometry_msgs::TwistWithCovarianceStamped::ConstPtr& msg) {
  warnIfNotImuFrame(msg->header.frame_id);
  std::lock_guard<std::mutex> lock(mutex_);
  bool covariance_invalid = false;
  const TwistData twist = ros_conversions::toTwistData(*msg, &covariance_invalid);
  onTwist(twist, covariance_invalid);
}

void VislamRos::odometryTwistCallback(const nav_msgs::Odometry::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The twist is that of child_frame_id: taken to the IMU frame through the (fixed) tf.
  Eigen::Isometry3d imu_T_child;
  if (!imu_T_frame_.lookup(msg->child_frame_id, &imu_T_child)) {
    ++twists_without_tf_;
    ROS_WARN_THROTTLE(5.0,
                      "%s: imu/twist odometry in frame '%s': no tf to '%s' yet; twist not used "
                      "(%lu so far)",
                      name_.c_str(), msg->child_frame_id.c_str(), ros_options_.imu_frame.c_str(),
                      static_cast<unsigned long>(twists_without_tf_));
    return;
  }
  bool covariance_invalid = false;
  const TwistData twist = ros_conversions::toTwistData(*msg, imu_T_child, &covariance_invalid);
  onTwist(twist, covariance_invalid);
}

void VislamRos::warnIfNotImuFrame(const std::string& frame_id) const {
  if (!frame_id.empty() && frame_id != ros_options_.imu_frame) {
    ROS_WARN_ONCE(
        "%s: imu/twist header.frame_id is '%s', expected ros/imu_frame '%s'; the twist "
        "is used as the IMU body-frame twist anyway",
        name_.c_str(), frame_id.c_str(), ros_options_.imu_frame.c_str());
  }
}

void VislamRos::onTwist(const TwistData& twist, bool covariance_invalid) {
  if (shut_down_) return;
  if (covariance_invalid) {
    ++twist_covariance_invalid_;
    ROS_WARN_THROTTLE(5.0,
                      "%s: imu/twist covariance not finite: the configured noise is used "
                      "(%lu so far)",
                      name_.c_str(), static_cast<unsigned long>(twist_covariance_invalid_));
  }
  ++twists_received_;
  last_twist_ = ros::WallTime::now();
  push(Measurement(twist));
  // Twist-rate odometry for control, from the propagated copy (the filter is not changed).
  const EstimatorRunner::Preview& preview = runner_->preview();
  if (publishing_ && preview.valid) {
    publishOdometry(preview.stamp, preview.world_T_imu, preview.pose_covariance_world,
                    preview.twist, preview.twist_covariance, false);
  }
}

void VislamRos::imuCallback(const sensor_msgs::Imu::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_) return;
  ++accel_received_;
  // Into the IMU frame (fixed tf: its axes turned, its origin the lever arm), once tf knows the
  // frame.
  accel_waiting_.push(msg);
  accel_waiting_.drain(
      ros_options_.tf_wait, &imu_T_frame_,
      [](const sensor_msgs::Imu& m) { return m.header.frame_id; },
      [this](const sensor_msgs::Imu& m, const Eigen::Isometry3d& imu_T_frame) {
        const std::optional<AccelerometerData> sample =
            ros_conversions::toAccelerometerData(m, imu_T_frame);
        if (sample) {
          push(Measurement(*sample));
          return;
        }
        ++accel_without_data_;
        ROS_WARN_ONCE(
            "%s: imu/data carries no accelerometer (linear_acceleration_covariance[0] = -1): no "
            "gravity update; set gravity/enabled false to silence this",
            name_.c_str());
      },
      [this](const sensor_msgs::Imu&, const std::string& frame) {
        ROS_WARN_THROTTLE(5.0,
                          "%s: imu/data in frame '%s': no tf to '%s' after %.1f s (message and "
                          "wall time); accelerometer sample not used (%lu so far)",
                          name_.c_str(), frame.c_str(), ros_options_.imu_frame.c_str(),
                          ros_options_.tf_wait,
                          static_cast<unsigned long>(accel_waiting_.droppedWithoutTf()));
      });
}

void VislamRos::featuresCallback(const ekf_vislam::StereoFeatureArray::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_) return;
  ++frames_received_;
  last_features_ = ros::WallTime::now();
  const double stamp = msg->header.stamp.toSec();
  const int missing = frame_gaps_.add(stamp);
  if (missing > 0) {
    ROS_WARN_THROTTLE(5.0,
                      "%s: %s: the feature source dropped them, the stream paused, or this node's "
                      "input queue (ros/queue_size) overflowed",
                      name_.c_str(),
                      frame_gaps_.describeMissing(missing, stamp, "feature frame").c_str());
  }
  if (camera_frame_.empty()) {
    // The features' frame, as vislam_offline takes it (the tracker's ros/rectify gives them in
    // the rectified camera's frame, not camera_info's); camera_info's only when they have none.
    camera_frame_ = !msg->header.frame_id.empty() ? msg->header.frame_id
                    : left_info_                  ? left_info_->header.frame_id
                                                  : "";
  }
  push(Measurement(ros_conversions::toFeatureFrame(*msg)));
}

void VislamRos::leftInfoCallback(const sensor_msgs::CameraInfo::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  left_info_ = msg;
  checkCameraInfoUnchanged(*msg, calibrated_left_, "left");
  tryCalibrate();
}

void VislamRos::rightInfoCallback(const sensor_msgs::CameraInfo::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  right_info_ = msg;
  checkCameraInfoUnchanged(*msg, calibrated_right_, "right");
  tryCalibrate();
}

void VislamRos::checkCameraInfoUnchanged(const sensor_msgs::CameraInfo& now,
                                         const std::optional<PinholeProjection>& calibrated,
                                         const char* side) {
  if (!calibrated || !runner_->estimator().hasCalibration()) return;
  const PinholeProjection& was = *calibrated;
  const PinholeProjection is = ros_conversions::projectionOf(now);
  if (sameProjection(is, was)) return;
  ++camera_info_changed_;
  ROS_WARN_THROTTLE(
      5.0,
      "%s: the %s camera_info changed after the calibration was set (fx %.3f -> %.3f, "
      "cx %.3f -> %.3f, P[0,3] %.3f -> %.3f, %dx%d -> %dx%d): ignored, the estimator "
      "keeps its calibration; restart the node to take the new one (%lu so far)",
      name_.c_str(), side, was.fx, is.fx, was.cx, is.cx, was.tx, is.tx, was.width, was.height,
      is.width, is.height, camera_info_changed_);
}

void VislamRos::push(Measurement measurement) {
  last_input_ = ros::WallTime::now();
  // The input topic of each MeasurementKind, in its order.
  static constexpr const char* kTopics[] = {"imu/twist", "stereo/features", "imu/data"};
  const char* topic = kTopics[static_cast<int>(kindOf(measurement))];
  const double stamp = stampOf(measurement);
  const uint64_t resets = runner_->timeJumpResets();
  runner_->push(std::move(measurement));
  if (runner_->timeJumpResets() != resets) {
    ROS_WARN(
        "%s: %s went back %.3f s in time (a bag played again?): estimator reset, map "
        "cleared, starting at %.3f s (%lu so far)",
        name_.c_str(), topic, runner_->lastTimeJump(), stamp,
        static_cast<unsigned long>(runner_->timeJumpResets()));
    clearOutputsLocked();
  }
  process(false);
}

void VislamRos::process(bool flush) {
  if (!runner_->estimator().hasCalibration()) tryCalibrate();
  if (holdForCalibration()) return;
  const auto observer = [this](const EstimatorRunner::Processed& p) { onProcessed(p); };
  if (flush) {
    runner_->flush(observer);
  } else {
    runner_->processReady(observer);
  }
  if (publishing_) publishTf();
}

bool VislamRos::holdForCalibration() {
  // At start the calibration (camera_info, latched /tf_static) races the first frames: keep the
  // measurements in the sequencer for up to ros/calibration_wait, so the first frames are used
  // (and the result does not depend on that race).
  if (options_.mode == EstimatorMode::kDeadReckoning || runner_->estimator().hasCalibration() ||
      calibration_wait_over_) {
    return false;
  }
  const ros::WallTime now = ros::WallTime::now();
  if (first_input_.isZero()) first_input_ = now;
  if ((now - first_input_).toSec() < ros_options_.calibration_wait) return true;
  calibration_wait_over_ = true;
  ROS_WARN("%s: no valid calibration after %.1f s (%s): processing without it", name_.c_str(),
           ros_options_.calibration_wait, calibration_status_.c_str());
  return false;
}

void VislamRos::tryCalibrate() {
  VislamEstimator& estimator = runner_->estimator();
  if (estimator.hasCalibration()) return;
  CalibrationBuilder builder(ros_options_.calibration);
  std::string error;
  if (builder.needsProjections()) {
    if (!left_info_ || !right_info_) {
      calibration_status_ = "waiting for camera_info (left and right)";
      return;
    }
    if (!builder.setProjections(ros_conversions::projectionOf(*left_info_),
                                ros_conversions::projectionOf(*right_info_), &error)) {
      reportRefusedCalibration("camera_info refused: " + error);
      return;
    }
  }
  if (builder.needsImuTCam() && !lookUpImuTCam(&builder)) return;
  StereoCalibration calibration;
  if (!builder.build(&calibration, &error) || !estimator.setCalibration(calibration, &error)) {
    reportRefusedCalibration(error);
    return;
  }
  calibration_status_ = "ok";
  if (builder.needsProjections()) {
    calibrated_left_ = ros_conversions::projectionOf(*left_info_);
    calibrated_right_ = ros_conversions::projectionOf(*right_info_);
  }
  const Eigen::Vector3d t = calibration.cam_T_imu.translation();
  ROS_INFO(
      "%s: calibration set: fx=%.3f fy=%.3f cx=%.3f cy=%.3f baseline=%.4f m, image %dx%d, "
      "cam_T_imu translation (%.4f, %.4f, %.4f) m",
      name_.c_str(), calibration.fx, calibration.fy, calibration.cx, calibration.cy,
      calibration.baseline, calibration.image_width, calibration.image_height, t.x(), t.y(), t.z());
}

bool VislamRos::lookUpImuTCam(CalibrationBuilder* builder) {
  if (camera_frame_.empty()) {
    calibration_status_ = "waiting for the camera frame id (stereo/features header.frame_id)";
    return false;
  }
  std::string tf_error;
  if (!tf_buffer_.canTransform(ros_options_.imu_frame, camera_frame_, ros::Time(0), &tf_error)) {
    calibration_status_ = "waiting for tf " + ros_options_.imu_frame + " -> " + camera_frame_;
    return false;
  }
  try {
    const geometry_msgs::TransformStamped imu_T_cam =
        tf_buffer_.lookupTransform(ros_options_.imu_frame, camera_frame_, ros::Time(0));
    builder->setImuTCam(ros_conversions::toIsometry(imu_T_cam.transform));
  } catch (const tf2::TransformException& e) {
    calibration_status_ = std::string("tf lookup failed: ") + e.what();
    return false;
  }
  return true;
}

void VislamRos::reportRefusedCalibration(const std::string& why) {
  calibration_status_ = why;
  if (why != rejected_calibration_) {
    ROS_ERROR("%s: %s", name_.c_str(), why.c_str());
    rejected_calibration_ = why;
  }
}

void VislamRos::onProcessed(const EstimatorRunner::Processed& processed) {
  const VislamEstimator& estimator = runner_->estimator();
  const bool is_frame = processed.kind == EstimatorRunner::Kind::kFrame;
  if (is_frame && processed.without_calibration) {
    ROS_WARN_THROTTLE(5.0,
                      "%s: no valid calibration yet (%s): feature frames are skipped, "
                      "prediction continues (%lu frames so far)",
                      name_.c_str(), calibration_status_.c_str(),
                      static_cast<unsigned long>(runner_->framesWithoutCalibration()));
  } else if (!processed.result.accepted) {
    ROS_WARN_THROTTLE(5.0, "%s: %s rejected: %s", name_.c_str(), kindName(processed.kind),
                      processed.result.message.c_str());
  } else if (!processed.result.message.empty()) {
    ROS_DEBUG("%s: %s", name_.c_str(), processed.result.message.c_str());
  }
  if (is_frame) {
    last_update_ms_ = processed.processing_ms;
    ++last_processed_count_;
  }
  if (!is_frame || !processed.result.accepted || !estimator.initialized()) return;
  last_stamp_ = estimator.time();
  if (publishing_) {
    publishOdometry(last_stamp_, estimator.worldTImu(), estimator.poseCovarianceWorld(),
                    estimator.correctedTwist(), estimator.correctedTwistCovariance(), true);
  }
  Eigen::Isometry3d imu_T_output;
  if (!runner_->trajectory().empty() && imuTOutput(&imu_T_output)) {
    geometry_msgs::PoseStamped pose;
    pose.header.frame_id = ros_options_.world_frame;
    pose.header.stamp = ros_conversions::toRosTime(runner_->trajectory().back().stamp);
    pose.pose = ros_conversions::toPoseMsg(runner_->trajectory().back().world_T_imu * imu_T_output);
    path_.poses.push_back(pose);
    path_.header.stamp = pose.header.stamp;
    path_dirty_ = true;
    landmarks_dirty_ = true;
  }
}

// ---------------------------------------------------------------------------------------------
// Outputs
// ---------------------------------------------------------------------------------------------

void VislamRos::publishOdometry(double stamp, const Eigen::Isometry3d& world_T_imu,
                                const Matrix6d& pose_covariance_world, const TwistData& twist,
                                const Matrix6d& twist_covariance, bool after_update) {
  Eigen::Isometry3d imu_T_output;
  if (!imuTOutput(&imu_T_output)) return;
  const AttachedFrameState output = moveToAttachedFrame(
      imu_T_output, world_T_imu, pose_covariance_world, twist, twist_covariance);
  nav_msgs::Odometry odometry;
  if (!ros_conversions::toOdometryMsg(stamp, ros_options_.world_frame, outputFrame(),
                                      output.world_T_frame, output.pose_covariance_world,
                                      output.twist, output.twist_covariance, &odometry)) {
    ++odometry_non_finite_;
    ROS_ERROR_THROTTLE(5.0, "%s: estimate not finite: odometry not published (%lu times)",
                       name_.c_str(), static_cast<unsigned long>(odometry_non_finite_));
    return;
  }
  // ~odometry never goes back in time: an update older than a prediction already published
  // (its frame came after later twists) reaches ~odometry through the next prediction.
  if (stamp >= last_odometry_stamp_) {
    odometry_pub_.publish(odometry);
    last_odometry_stamp_ = stamp;
  }
  if (!after_update) return;
  // tf follows the filter (once per update): a prediction at a frame's stamp must not take the
  // place of that frame's update (tf2 keeps the first transform of a stamp).
  odometry_update_pub_.publish(odometry);
  last_odometry_ = odometry;
  has_odometry_ = true;
}

void VislamRos::publishTf() {
  // Once per stamp: a twist and a frame often share one, and tf2 drops repeated stamps.
  if (!has_odometry_ || !ros_options_.publish_tf || last_odometry_.header.stamp == last_tf_stamp_) {
    return;
  }
  geometry_msgs::TransformStamped transform;
  transform.header = last_odometry_.header;
  transform.child_frame_id = outputFrame();
  transform.transform.translation.x = last_odometry_.pose.pose.position.x;
  transform.transform.translation.y = last_odometry_.pose.pose.position.y;
  transform.transform.translation.z = last_odometry_.pose.pose.position.z;
  transform.transform.rotation = last_odometry_.pose.pose.orientation;
  tf_broadcaster_.sendTransform(transform);
  last_tf_stamp_ = transform.header.stamp;
}

const std::string& VislamRos::outputFrame() const {
  return ros_options_.base_frame.empty() ? ros_options_.imu_frame : ros_options_.base_frame;
}

bool VislamRos::imuTOutput(Eigen::Isometry3d* imu_T_output) {
  std::string why;
  if (imu_T_frame_.lookup(outputFrame(), imu_T_output, &why)) return true;
  ++base_frame_without_tf_;
  ROS_WARN_THROTTLE(5.0,
                    "%s: no tf %s -> ros/base_frame %s yet (%s): odometry, tf and path not "
                    "published (%lu times so far)",
                    name_.c_str(), ros_options_.imu_frame.c_str(), outputFrame().c_str(),
                    why.c_str(), static_cast<unsigned long>(base_frame_without_tf_));
  return false;
}

void VislamRos::publishPath() {
  if (path_pub_.getNumSubscribers() > 0 || path_pub_.isLatched()) path_pub_.publish(path_);
  path_dirty_ = false;
}

void VislamRos::publishLandmarks() {
  landmarks_dirty_ = false;
  landmarks_pub_.publish(ros_markers::landmarkMarkers(runner_->estimator().landmarks(),
                                                      ros_conversions::toRosTime(last_stamp_),
                                                      ros_options_, &previous_ellipsoids_));
}

void VislamRos::clearVisualization() {
  landmarks_pub_.publish(ros_markers::clearedMarkers(ros_options_));
  previous_ellipsoids_ = 0;
  path_pub_.publish(path_);
}

void VislamRos::waitTimer(const ros::WallTimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_ || runner_->buffered() == 0) return;
  process(false);
}

void VislamRos::visualizationTimer(const ros::WallTimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_) return;
  const ros::WallTime now = ros::WallTime::now();
  if (ros_options_.landmark_marker_rate > 0.0 && landmarks_dirty_ &&
      (now - last_landmarks_publish_).toSec() >= 0.999 / ros_options_.landmark_marker_rate) {
    last_landmarks_publish_ = now;
    publishLandmarks();
  }
  if (ros_options_.path_rate > 0.0 && path_dirty_ &&
      (now - last_path_publish_).toSec() >= 0.999 / ros_options_.path_rate) {
    last_path_publish_ = now;
    publishPath();
  }
}

bool VislamRos::resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  runner_->reset();
  frame_gaps_.reset();
  clearOutputsLocked();
  ROS_INFO("%s: reset: pose back at identity, map cleared", name_.c_str());
  response.success = true;
  response.message = "estimator reset";
  return true;
}

void VislamRos::clearOutputsLocked() {
  last_odometry_stamp_ = -1e300;  // time starts again
  path_.poses.clear();
  path_dirty_ = false;
  landmarks_dirty_ = false;
  if (publishing_) clearVisualization();
}

bool VislamRos::saveService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string message;
  response.success = saveLocked(&message);
  response.message = message;
  return true;
}

bool VislamRos::saveLocked(std::string* message) {
  // ~ros/output_dir is read again here, so the target can be changed while running.
  std::string dir = ros_options_.output_dir;
  if (!shut_down_ && pnh_.getParam("ros/output_dir", dir)) ros_options_.output_dir = dir;
  if (dir.empty()) {
    *message = "parameter ros/output_dir is not set: nothing saved";
    return false;
  }
  std::string error;
  if (!runner_->save(dir, &error)) {
    *message = "save failed: " + error;
    return false;
  }
  *message = "saved " + std::to_string(runner_->trajectory().size()) + " poses and " +
             std::to_string(landmarksInMap(runner_->estimator().landmarks())) + " landmarks to " +
             dir;
  return true;
}

}  // namespace ekf_vislam
