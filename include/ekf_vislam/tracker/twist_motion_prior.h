// The left camera's motion between two images predicted from a body twist (an IMU or wheel
// odometry), for the tracker's KLT start points: the nodelet (imu/twist) and the offline tool
// (--predict-with-twist) both use it. No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>

#include <deque>
#include <optional>

namespace ekf_vislam {

/// One body-frame twist sample: v (m/s) and w (rad/s) in the twist's frame, held over the
/// interval that ends at `stamp` (sample k drives [t_(k-1), t_k]).
struct StampedTwist {
  double stamp = 0.0;  ///< s
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
};

/// Appends `sample` when it is newer than the last twist (false otherwise: not kept), then drops
/// the twists no prior will need: those before both `last_tracked_stamp` (the last tracked pair's
/// stamp, <= 0 before the first) and the last 5 s. The nodelet and track_stereo_bag keep them so.
bool keepTwist(const StampedTwist& sample, double last_tracked_stamp,
               std::deque<StampedTwist>* twists);

/// The motion of the left camera from `from` to `to` (s): the twists (stamp order) integrated on
/// SE(3) over the interval, each over the part of it that it drives, then moved into the camera
/// frame with cam_T_imu (the twist's frame to the left camera). Empty when the twists do not
/// reach `to` or the interval is empty.
std::optional<CameraMotionPrior> motionPriorFromTwists(const std::deque<StampedTwist>& twists,
                                                       const Eigen::Matrix4d& cam_T_imu,
                                                       double from, double to);

}  // namespace ekf_vislam
