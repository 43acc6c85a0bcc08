// ParameterSource over the ROS parameter server: key "noise/pixel_sigma" is read from
// <node handle namespace>/noise/pixel_sigma (the private namespace for the nodelet/node), so a
// YAML file loaded with <rosparam command="load"> inside the node gives the same options as the
// offline runner's YamlParameterSource on that file.
#pragma once

#include "ekf_vislam/core/parameter_source.h"

#include <ros/node_handle.h>

#include <string>

namespace ekf_vislam {

class RosParameterSource : public ParameterSource {
 public:
  explicit RosParameterSource(const ros::NodeHandle& nh) : nh_(nh) {}

  bool has(const std::string& key) const override;
  /// Accepts integers too.
  bool getDouble(const std::string& key, double* value) const override;
  bool getInt(const std::string& key, int* value) const override;
  bool getBool(const std::string& key, bool* value) const override;
  /// Accepts a list of numbers too, returned space-separated (e.g. calibration/cam_T_imu).
  bool getString(const std::string& key, std::string* value) const override;
  std::string describe() const override;
  /// The parameters below the node handle's namespace, relative to it.
  std::vector<std::string> keys() const override;

 private:
  ros::NodeHandle nh_;
};

}  // namespace ekf_vislam
