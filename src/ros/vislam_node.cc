// vislam_node: the standalone node of EKF stereo visual-inertial SLAM, a thin main over VislamRos
// (same behaviour as the nodelet ekf_vislam/VislamNodelet).
#include "ekf_vislam/ros/thin_wrappers.h"
#include "ekf_vislam/ros/vislam_ros.h"

int main(int argc, char** argv) {
  return ekf_vislam::runNode<ekf_vislam::VislamRos>(argc, argv, "vislam");
}
