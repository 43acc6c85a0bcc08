// ekf_vislam/VislamNodelet: a thin nodelet over VislamRos.
#include "ekf_vislam/ros/vislam_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace ekf_vislam {

class VislamNodelet : public nodelet::Nodelet {
 public:
  ~VislamNodelet() override {
    if (vislam_) vislam_->shutdown();  // processes what is buffered, saves when configured
  }

 private:
  void onInit() override {
    vislam_ = std::make_unique<VislamRos>(getNodeHandle(), getPrivateNodeHandle(), getName());
  }

  std::unique_ptr<VislamRos> vislam_;
};

}  // namespace ekf_vislam

PLUGINLIB_EXPORT_CLASS(ekf_vislam::VislamNodelet, nodelet::Nodelet)
