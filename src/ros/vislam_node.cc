// vislam_node: the standalone node, a thin main over VislamRos (same behaviour as the nodelet).
#include "ekf_vislam/ros/vislam_ros.h"

#include <ros/ros.h>

#include <exception>

int main(int argc, char** argv) {
  ros::init(argc, argv, "vislam");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try {
    ekf_vislam::VislamRos vislam(nh, pnh, ros::this_node::getName());
    ros::spin();
    vislam.shutdown();  // processes what is buffered, saves when ros/output_dir is set
  } catch (const std::exception& e) {
    ROS_FATAL("%s: %s", ros::this_node::getName().c_str(), e.what());
    return 1;
  }
  return 0;
}
