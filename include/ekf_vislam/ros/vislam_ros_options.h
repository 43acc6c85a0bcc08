// Settings of the ROS layer (nodelet/node and the offline bag runner) under the "ros/" key
// prefix of the same parameter source the core options come from (config/default.yaml, section
// "ros:"). No ROS include: parsed from a YAML file or from the parameter server alike.
#pragma once

#include "ekf_vislam/core/calibration_builder.h"
#include "ekf_vislam/core/parameter_source.h"
#include "ekf_vislam/core/twist_message_type.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <string>
#include <vector>

namespace ekf_vislam {

struct VislamRosOptions {
  std::string world_frame = "world";  ///< ros/world_frame
  std::string imu_frame = "imu";      ///< ros/imu_frame
  /// ros/base_frame: the robot frame odometry, tf and the path are given for ("" = imu_frame)
  std::string base_frame;
  /// ros/twist_type: message type on imu/twist: twist_stamped | twist_with_covariance | odometry
  TwistMessageType twist_type = TwistMessageType::kTwistStamped;
  bool publish_tf = true;              ///< ros/publish_tf: world -> imu
  double landmark_marker_rate = 2.0;   ///< ros/landmark_marker_rate, Hz (0 = never)
  bool covariance_ellipsoids = false;  ///< ros/covariance_ellipsoids (active landmarks)
  double ellipsoid_sigma_scale = 3.0;  ///< ros/ellipsoid_sigma_scale: ellipsoid half-axes in sigma
  double landmark_point_size = 0.5;    ///< ros/landmark_point_size, m (active ones: twice)
  double landmark_sigma_good = 0.25;   ///< ros/landmark_sigma_good, m: green at or below
  double landmark_sigma_bad = 10.0;    ///< ros/landmark_sigma_bad, m: red at or above
  double path_rate = 2.0;              ///< ros/path_rate, Hz (0 = never)
  double diagnostic_period = 1.0;      ///< ros/diagnostic_period, s
  double input_timeout = 1.0;          ///< ros/input_timeout, wall s: diagnostics WARN after
  double calibration_wait = 2.0;       ///< ros/calibration_wait, wall s inputs are held at start
  double sequencer_max_delay = 10.0;   ///< ros/sequencer_max_delay, s of message and wall time
  int sequencer_max_buffered = 2000;   ///< ros/sequencer_max_buffered, messages
  int queue_size = 2000;               ///< ros/queue_size of every subscriber
  double time_jump_reset = 1.0;        ///< ros/time_jump_reset, s (0 = off)
  double tf_wait = 1.0;    ///< ros/tf_wait, s (message and wall time) an input waits for tf
  std::string output_dir;  ///< ros/output_dir: save target ("" = no saving)
  CalibrationOverride calibration;  ///< ros/calibration/...

  std::string validate() const;
};

/// Fills `options` from the "ros/" keys of `source`; absent keys keep their values. False with a
/// message naming the key for values of the wrong type or out of range.
bool parseVislamRosOptions(const ParameterSource& source, VislamRosOptions* options,
                           std::string* error);

/// One multi-line, human-readable listing of the effective ros/ options (logged at start).
std::string describeOptions(const VislamRosOptions& options);

/// Every key of the ros/ key table (the ros/calibration/ group aside).
std::vector<OptionKeyList::Key> vislamRosOptionKeys();

/// The keys of an estimator configuration (config/default.yaml: the core's options, ros/ and
/// ros/calibration/) that `source` holds but nothing reads, as one line to warn with ("" when
/// none; parameter_source.h).
std::string unknownEstimatorKeys(const ParameterSource& source);

}  // namespace ekf_vislam
