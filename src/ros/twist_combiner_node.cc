// twist_combiner_node: the standalone node, a thin main over TwistCombinerRos (same behaviour
// as the nodelet).
#include "ekf_vislam/ros/twist_combiner_ros.h"

#include <ros/ros.h>

#include <exception>

int main(int argc, char** argv) {
  ros::init(argc, argv, "twist_combiner");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try {
    ekf_vislam::TwistCombinerRos combiner(nh, pnh, ros::this_node::getName());
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), e.what());
    return 1;
  }
  return 0;
}
