// ekf_vislam/TwistCombinerNodelet: a thin nodelet over TwistCombinerRos.
#include "ekf_vislam/ros/twist_combiner_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace ekf_vislam {

class TwistCombinerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    combiner_ =
        std::make_unique<TwistCombinerRos>(getNodeHandle(), getPrivateNodeHandle(), getName());
  }
  std::unique_ptr<TwistCombinerRos> combiner_;
};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::TwistCombinerNodelet, nodelet::Nodelet)
