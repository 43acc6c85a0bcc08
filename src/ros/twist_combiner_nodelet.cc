// ekf_vislam/TwistCombinerNodelet: a thin nodelet over TwistCombinerRos.
#include "ekf_vislam/ros/thin_wrappers.h"
#include "ekf_vislam/ros/twist_combiner_ros.h"

#include <pluginlib/class_list_macros.hpp>

namespace ekf_vislam {

class TwistCombinerNodelet : public WrapperNodelet<TwistCombinerRos> {};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::TwistCombinerNodelet, nodelet::Nodelet)
