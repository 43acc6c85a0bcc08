// ekf_vislam/StereoTrackerNodelet: a thin nodelet over StereoTrackerRos.
#include "ekf_vislam/ros/stereo_tracker_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace ekf_vislam {

class StereoTrackerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    tracker_ =
        std::make_unique<StereoTrackerRos>(getNodeHandle(), getPrivateNodeHandle(), getName());
  }
  std::unique_ptr<StereoTrackerRos> tracker_;
};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::StereoTrackerNodelet, nodelet::Nodelet)
