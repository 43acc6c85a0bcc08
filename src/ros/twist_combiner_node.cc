// twist_combiner_node: the standalone node of the twist combiner, a thin main over TwistCombinerRos
// (same behaviour as the nodelet ekf_vislam/TwistCombinerNodelet).
#include "ekf_vislam/ros/thin_wrappers.h"
#include "ekf_vislam/ros/twist_combiner_ros.h"

int main(int argc, char** argv) {
  return ekf_vislam::runNode<ekf_vislam::TwistCombinerRos>(argc, argv, "twist_combiner");
}
