// stereo_tracker_node: the standalone node of the stereo tracker, a thin main over StereoTrackerRos
// (same behaviour as the nodelet ekf_vislam/StereoTrackerNodelet).
#include "ekf_vislam/ros/stereo_tracker_ros.h"
#include "ekf_vislam/ros/thin_wrappers.h"

int main(int argc, char** argv) {
  return ekf_vislam::runNode<ekf_vislam::StereoTrackerRos>(argc, argv, "stereo_tracker");
}
