// The message type a node takes its body twist from on imu/twist: the ros/twist_type key of the
// estimator and of the stereo tracker alike. No ROS.
#pragma once

#include "ekf_vislam/core/option_table.h"

namespace ekf_vislam {

enum class TwistMessageType {
  kTwistStamped,         ///< geometry_msgs/TwistStamped
  kTwistWithCovariance,  ///< geometry_msgs/TwistWithCovarianceStamped
  kOdometry,             ///< nav_msgs/Odometry: its twist, in child_frame_id
};

inline constexpr EnumNames<TwistMessageType, 3> kTwistMessageTypeNames{
    {{"twist_stamped", TwistMessageType::kTwistStamped},
     {"twist_with_covariance", TwistMessageType::kTwistWithCovariance},
     {"odometry", TwistMessageType::kOdometry}}};

}  // namespace ekf_vislam
