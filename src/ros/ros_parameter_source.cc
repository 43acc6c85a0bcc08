#include "ekf_vislam/ros/ros_parameter_source.h"

#include <XmlRpcValue.h>

#include <algorithm>
#include <sstream>

namespace ekf_vislam {

bool RosParameterSource::has(const std::string& key) const { return nh_.hasParam(key); }

bool RosParameterSource::getDouble(const std::string& key, double* value) const {
  XmlRpc::XmlRpcValue raw;
  if (!nh_.getParam(key, raw)) return false;
  if (raw.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    *value = static_cast<double>(raw);
    return true;
  }
  if (raw.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    *value = static_cast<int>(raw);
    return true;
  }
  return false;
}

bool RosParameterSource::getInt(const std::string& key, int* value) const {
  XmlRpc::XmlRpcValue raw;
  if (!nh_.getParam(key, raw) || raw.getType() != XmlRpc::XmlRpcValue::TypeInt) return false;
  *value = static_cast<int>(raw);
  return true;
}

bool RosParameterSource::getBool(const std::string& key, bool* value) const {
  XmlRpc::XmlRpcValue raw;
  if (!nh_.getParam(key, raw) || raw.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return false;
  *value = static_cast<bool>(raw);
  return true;
}

bool RosParameterSource::getString(const std::string& key, std::string* value) const {
  XmlRpc::XmlRpcValue raw;
  if (!nh_.getParam(key, raw)) return false;
  if (raw.getType() == XmlRpc::XmlRpcValue::TypeString) {
    *value = static_cast<std::string>(raw);
    return true;
  }
  if (raw.getType() == XmlRpc::XmlRpcValue::TypeArray) {
    std::ostringstream joined;
    joined.precision(17);
    for (int i = 0; i < raw.size(); ++i) {
      XmlRpc::XmlRpcValue& item = raw[i];
      if (i > 0) joined << ' ';
      if (item.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
        joined << static_cast<double>(item);
      } else if (item.getType() == XmlRpc::XmlRpcValue::TypeInt) {
        joined << static_cast<int>(item);
      } else {
        return false;
      }
    }
    *value = joined.str();
    return true;
  }
  return false;
}

std::string RosParameterSource::describe() const {
  return "ROS parameters under " + nh_.getNamespace();
}

std::vector<std::string> RosParameterSource::keys() const {
  std::vector<std::string> all, keys;
  if (!nh_.getParamNames(all)) return keys;
  const std::string prefix = nh_.getNamespace() + "/";
  for (const std::string& name : all) {
    if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0) {
      keys.push_back(name.substr(prefix.size()));
    }
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

}  // namespace ekf_vislam
