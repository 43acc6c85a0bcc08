// ParameterSource over a YAML file (yaml-cpp). No ROS.
#pragma once

#include "ekf_vislam/core/parameter_source.h"

#include <memory>
#include <string>

namespace YAML {
class Node;
}

namespace ekf_vislam {

class YamlParameterSource : public ParameterSource {
 public:
  /// Loads `path`; on failure ok() is false and error() says why (file missing, syntax error).
  explicit YamlParameterSource(const std::string& path);
  /// Parses YAML text (tests).
  static YamlParameterSource fromString(const std::string& yaml_text);
  ~YamlParameterSource() override;
  YamlParameterSource(YamlParameterSource&&) noexcept;

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

  bool has(const std::string& key) const override;
  bool getDouble(const std::string& key, double* value) const override;
  bool getInt(const std::string& key, int* value) const override;
  bool getBool(const std::string& key, bool* value) const override;
  bool getString(const std::string& key, std::string* value) const override;
  std::string describe() const override { return origin_; }
  std::vector<std::string> keys() const override;

 private:
  YamlParameterSource() = default;
  bool lookup(const std::string& key, YAML::Node* node) const;

  std::unique_ptr<YAML::Node> root_;
  std::string origin_;
  std::string error_;
};

}  // namespace ekf_vislam
