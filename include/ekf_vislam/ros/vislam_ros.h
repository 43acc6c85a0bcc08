// The one ROS wrapper of the estimator, shared by the nodelet (ekf_vislam/VislamNodelet) and the
// node (vislam_node). Owns an EstimatorRunner (estimator + measurement sequencer); the estimator
// itself never sees ROS.
//
// Subscribes (relative names, remappable): imu/twist (geometry_msgs/TwistStamped,
// TwistWithCovarianceStamped or nav_msgs/Odometry by ros/twist_type),
// stereo/features (ekf_vislam/StereoFeatureArray), stereo/left/camera_info and
// stereo/right/camera_info (sensor_msgs/CameraInfo); imu_T_cam from tf (imu_frame -> the
// features' header.frame_id).
// Publishes (private names): odometry (nav_msgs/Odometry: at every twist from the propagated copy,
// stamp = the twist's, and after every update, stamp = the frame's), odometry_update (only the
// filter's pose after each update), path (nav_msgs/Path), landmarks
// (visualization_msgs/MarkerArray), tf world_frame -> imu_frame (after every update), /diagnostics.
// Services (private): reset, save (std_srvs/Trigger).
// Parameters (private): the core options (config/default.yaml) and the ros/ section.
#pragma once

#include <ekf_vislam/StereoFeature.h>
#include <ekf_vislam/StereoFeatureArray.h>
#include "ekf_vislam/core/counter_window.h"
#include "ekf_vislam/core/estimator_hints.h"
#include "ekf_vislam/core/estimator_runner.h"
#include "ekf_vislam/core/stamp_gap_detector.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/ros/periodic_diagnostics.h"
#include "ekf_vislam/ros/tf_waiting_queue.h"
#include "ekf_vislam/ros/vislam_ros_options.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Imu.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <array>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace ekf_vislam {

class VislamRos {
 public:
  /// nh: namespace of the inputs; pnh: private namespace (parameters, outputs, services).
  /// Throws std::runtime_error when the parameters are invalid (logged with ROS_FATAL first).
  VislamRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name);
  ~VislamRos();

  /// Processes what is still buffered and saves to ros/output_dir when set. Idempotent.
  void shutdown();

 private:
  // Construction: parameters (throws on invalid ones), publishers, subscribers, then timers,
  // diagnostics and services.
  void loadOptions();
  void advertiseOutputs();
  void subscribeInputs();
  void startTimersAndServices();

  // Inputs.
  void twistCallback(const geometry_msgs::TwistStamped::ConstPtr& msg);
  void twistWithCovarianceCallback(const geometry_msgs::TwistWithCovarianceStamped::ConstPtr& msg);
  void odometryTwistCallback(const nav_msgs::Odometry::ConstPtr& msg);
  void warnIfNotImuFrame(const std::string& frame_id) const;
  void onTwist(const TwistData& twist, bool covariance_invalid);  // locked
  /// imu/data: the accelerometer for the gravity update (gravity/enabled, SLAM mode).
  void imuCallback(const sensor_msgs::Imu::ConstPtr& msg);
  void featuresCallback(const ekf_vislam::StereoFeatureArray::ConstPtr& msg);
  void leftInfoCallback(const sensor_msgs::CameraInfo::ConstPtr& msg);
  void rightInfoCallback(const sensor_msgs::CameraInfo::ConstPtr& msg);
  /// After the calibration is set: counts and warns a camera_info whose projection or image size
  /// differs from the one the calibration was built from (the estimator keeps its calibration).
  void checkCameraInfoUnchanged(const sensor_msgs::CameraInfo& now,
                                const std::optional<PinholeProjection>& calibrated,
                                const char* side);  // locked
  void push(Measurement measurement);               // locked
  void process(bool flush);                         // locked
  void onProcessed(const EstimatorRunner::Processed& processed);
  void tryCalibrate();
  /// tf imu_frame -> camera frame into the builder; false (status set) while it is not there.
  bool lookUpImuTCam(CalibrationBuilder* builder);
  /// Status and one error log per distinct reason.
  void reportRefusedCalibration(const std::string& why);  // locked
  bool holdForCalibration();                              // locked

  // Outputs.
  /// Publishes on ~odometry (and on ~odometry_update when `after_update`).
  void publishOdometry(double stamp, const Eigen::Isometry3d& world_T_imu,
                       const Matrix6d& pose_covariance_world, const TwistData& twist,
                       const Matrix6d& twist_covariance, bool after_update);
  void publishTf();
  /// The frame odometry, tf and the path are given for: ros/base_frame, or the IMU's.
  const std::string& outputFrame() const;
  /// imu_T_output from tf (cached: fixed); false, counted and warned while tf has none.
  bool imuTOutput(Eigen::Isometry3d* imu_T_output);
  void publishPath();
  void publishLandmarks();
  void clearVisualization();
  /// Every 0.1 s of wall time: processes what the calibration wait or the sequencer held back.
  void waitTimer(const ros::WallTimerEvent&);
  void visualizationTimer(const ros::WallTimerEvent&);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// What the log and the status say about the inputs and the regime (empty: nothing).
  struct DiagnosticHints {
    std::string disagreement;  ///< many observations gated in the last period
    StateHints state;          ///< the hints read from the estimator's state (estimator_hints.h)
  };
  /// The hints of this period, each warned (throttled) in the log.
  DiagnosticHints collectHints(const EstimatorStats& stats, double dt);
  /// The status level and message: the most serious condition first.
  void setSummary(const DiagnosticHints& hints, const ros::WallTime& now,
                  diagnostic_updater::DiagnosticStatusWrapper& status) const;
  /// Every key of the status (rates, timing, landmarks, calibration, counters).
  void addDiagnosticValues(double twist_rate, double feature_rate,
                           diagnostic_updater::DiagnosticStatusWrapper& status) const;
  /// Closes the observation-rate window once it holds kSparseHintMinFrames frames: sets
  /// observations_per_frame_, sparse_hint_ and widened_hint_ (warned in the log).
  void updateObservationRate(const EstimatorStats& stats);
  /// Closes the feature-geometry window once it holds kFeatureHintMinObservations observations:
  /// sets geometry_hint_ (warned in the log).
  void updateFeatureGeometry(const EstimatorStats& stats);

  bool resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response);
  /// After a reset: path and markers cleared, odometry time starts again (locked).
  void clearOutputsLocked();
  bool saveService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response);
  bool saveLocked(std::string* message);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  std::string name_;
  VislamOptions options_;
  VislamRosOptions ros_options_;

  std::mutex mutex_;
  std::unique_ptr<EstimatorRunner> runner_;
  bool shut_down_ = false;
  bool publishing_ = true;

  // Calibration.
  sensor_msgs::CameraInfo::ConstPtr left_info_;
  sensor_msgs::CameraInfo::ConstPtr right_info_;
  /// The projections the calibration was built from (none with ros/calibration intrinsics).
  std::optional<PinholeProjection> calibrated_left_, calibrated_right_;
  uint64_t camera_info_changed_ = 0;  ///< camera_info messages unlike the calibration's, ignored
  std::string camera_frame_;
  std::string calibration_status_ = "waiting for camera_info and tf";
  /// Parameters in the private namespace that no option reads (typing mistakes), or "".
  std::string unknown_parameters_;
  std::string rejected_calibration_;  ///< last refused calibration message (logged once each)
  ros::WallTime first_input_;
  bool calibration_wait_over_ = false;

  // Counters and rates (wall clock).
  ros::WallTime last_input_;
  ros::WallTime last_twist_;
  ros::WallTime last_features_;
  uint64_t twists_received_ = 0;
  uint64_t twist_covariance_invalid_ = 0;
  uint64_t twists_without_tf_ = 0;
  uint64_t accel_received_ = 0;
  uint64_t accel_without_data_ = 0;  ///< Imu messages whose accelerometer is marked missing
  /// imu/data messages until tf knows their frame (ros/tf_wait of message time and of wall time).
  TfWaitingQueue<sensor_msgs::Imu> accel_waiting_{"imu/data"};
  FixedFrameTransforms imu_T_frame_;    ///< imu_frame <- input frames (fixed tf, cached)
  uint64_t base_frame_without_tf_ = 0;  ///< outputs not published: no tf to base_frame
  uint64_t frames_received_ = 0;
  StampGapDetector frame_gaps_;  ///< feature frames missing, from gaps in their stamps
  uint64_t twists_at_last_diag_ = 0;
  uint64_t frames_at_last_diag_ = 0;
  ros::WallTime last_diag_;
  uint64_t odometry_non_finite_ = 0;
  uint64_t divergence_at_last_diag_ = 0;
  bool diverging_ = false;
  /// Observations gated and used in updates, per diagnostics period (the disagreement hint).
  CounterWindow<2> disagreement_window_;
  // Observations per frame over windows of at least kSparseHintMinFrames frames.
  /// Frames used, observations used in updates, frames whose prediction was widened.
  CounterWindow<3> rate_window_;
  double observations_per_frame_ = -1.0;  ///< over the last full window (-1: none yet)
  /// When each state hint was last warned in the log (once a minute at most).
  std::array<ros::WallTime, StateHints::kCount> state_hint_warned_;
  std::string sparse_hint_;   ///< sparseObservationsHint of that window
  std::string widened_hint_;  ///< widenedPredictionHint of that window
  // Rejected stereo geometry over windows of at least kFeatureHintMinObservations observations.
  CounterWindow<3> geometry_window_;  ///< observations screened, rejected for rows, disparity
  std::string geometry_hint_;         ///< featureGeometryHint of the last full window
  double last_update_ms_ = 0.0;
  int last_processed_count_ = 0;

  // Publishing.
  ros::Subscriber twist_sub_, features_sub_, left_info_sub_, right_info_sub_, imu_sub_;
  ros::Publisher odometry_pub_, odometry_update_pub_, path_pub_, landmarks_pub_;
  ros::ServiceServer reset_srv_, save_srv_;
  ros::WallTimer wait_timer_, landmark_timer_;
  ros::WallTime last_landmarks_publish_;
  ros::WallTime last_path_publish_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  nav_msgs::Path path_;
  nav_msgs::Odometry last_odometry_;
  double last_odometry_stamp_ = -1e300;  ///< of the last ~odometry message
  bool has_odometry_ = false;
  ros::Time last_tf_stamp_;
  bool path_dirty_ = false;
  bool landmarks_dirty_ = false;
  size_t previous_ellipsoids_ = 0;
  double last_stamp_ = 0.0;
  std::unique_ptr<PeriodicDiagnostics> diagnostics_;
};

}  // namespace ekf_vislam
