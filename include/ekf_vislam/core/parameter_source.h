// Where options come from: a YAML file (offline runner) or the ROS parameter server (nodelet).
// One parser (parseVislamOptions) reads either through this interface. No ROS.
#pragma once

#include <string>
#include <vector>

namespace ekf_vislam {

/// Read-only key/value lookup. Keys are '/'-separated paths into nested maps, e.g.
/// "noise/pixel_sigma". Each getter returns false when the key is absent and throws nothing;
/// a present key of the wrong type sets *type_error (when given) and returns false.
class ParameterSource {
 public:
  virtual ~ParameterSource() = default;
  virtual bool has(const std::string& key) const = 0;
  virtual bool getDouble(const std::string& key, double* value) const = 0;
  virtual bool getInt(const std::string& key, int* value) const = 0;
  virtual bool getBool(const std::string& key, bool* value) const = 0;
  virtual bool getString(const std::string& key, std::string* value) const = 0;
  /// Human-readable origin for error messages, e.g. "config/default.yaml".
  virtual std::string describe() const = 0;
  /// Every key the source holds a value for (maps are walked, anything else is a value), sorted.
  virtual std::vector<std::string> keys() const = 0;
};

/// The keys of `source` that are neither in `known` nor below one of `known_groups` (e.g.
/// "ros/calibration/"): typing mistakes, which would otherwise be ignored in silence.
std::vector<std::string> unknownKeys(const ParameterSource& source,
                                     const std::vector<std::string>& known,
                                     const std::vector<std::string>& known_groups = {});

/// "" when `unknown` is empty, else one line naming each key and the known key nearest to it:
/// "unknown keys ignored: vehicle/tilt_sigm (vehicle/tilt_sigma?)".
std::string describeUnknownKeys(const std::vector<std::string>& unknown,
                                const std::vector<std::string>& known);

}  // namespace ekf_vislam
