// ekf_vislam/VislamNodelet: a thin nodelet over VislamRos.
#include "ekf_vislam/ros/thin_wrappers.h"
#include "ekf_vislam/ros/vislam_ros.h"

#include <pluginlib/class_list_macros.hpp>

namespace ekf_vislam {

class VislamNodelet : public WrapperNodelet<VislamRos> {};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::VislamNodelet, nodelet::Nodelet)
