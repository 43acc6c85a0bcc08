// One diagnostic_updater task of a node (hardware id "ekf_vislam"), published every `period` s of
// wall time: the set-up each ROS wrapper of the package (estimator, stereo tracker, twist
// combiner) needs.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <string>

namespace ekf_vislam {

class PeriodicDiagnostics {
 public:
  template <typename Owner>
  PeriodicDiagnostics(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                      const std::string& name, const std::string& task, double period, Owner* owner,
                      void (Owner::*produce)(diagnostic_updater::DiagnosticStatusWrapper&))
      : updater_(nh, pnh, name) {
    updater_.setHardwareID("ekf_vislam");
    updater_.add(task, owner, produce);
    ros::NodeHandle timer_handle(nh);
    timer_ = timer_handle.createWallTimer(
        ros::WallDuration(period), [this](const ros::WallTimerEvent&) { updater_.force_update(); });
  }
  PeriodicDiagnostics(const PeriodicDiagnostics&) = delete;
  PeriodicDiagnostics& operator=(const PeriodicDiagnostics&) = delete;

  void stop() { timer_.stop(); }

 private:
  diagnostic_updater::Updater updater_;
  ros::WallTimer timer_;
};

}  // namespace ekf_vislam
