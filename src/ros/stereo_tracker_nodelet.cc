// ekf_vislam/StereoTrackerNodelet: a thin nodelet over StereoTrackerRos.
#include "ekf_vislam/ros/stereo_tracker_ros.h"
#include "ekf_vislam/ros/thin_wrappers.h"

#include <pluginlib/class_list_macros.hpp>

namespace ekf_vislam {

class StereoTrackerNodelet : public WrapperNodelet<StereoTrackerRos> {};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::StereoTrackerNodelet, nodelet::Nodelet)
