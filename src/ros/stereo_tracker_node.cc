// stereo_tracker_node: the standalone node, a thin main over StereoTrackerRos (same behaviour
// as the nodelet).
#include "ekf_vislam/ros/stereo_tracker_ros.h"

#include <ros/ros.h>

#include <exception>

int main(int argc, char** argv) {
  ros::init(argc, argv, "stereo_tracker");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try {
    ekf_vislam::StereoTrackerRos tracker(nh, pnh, ros::this_node::getName());
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), e.what());
    return 1;
  }
  return 0;
}
