#include "ekf_vislam/core/yaml_parameter_source.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <sstream>

namespace ekf_vislam {

YamlParameterSource::YamlParameterSource(const std::string& path) : origin_(path) {
  try {
    root_ = std::make_unique<YAML::Node>(YAML::LoadFile(path));
  } catch (const YAML::BadFile&) {
    error_ = path + ": cannot open file";
  } catch (const YAML::Exception& e) {
    error_ = path + ": " + e.what();
  }
}

YamlParameterSource YamlParameterSource::fromString(const std::string& yaml_text) {
  YamlParameterSource source;
  source.origin_ = "<yaml text>";
  try {
    source.root_ = std::make_unique<YAML::Node>(YAML::Load(yaml_text));
  } catch (const YAML::Exception& e) {
    source.error_ = std::string("<yaml text>: ") + e.what();
  }
  return source;
}

YamlParameterSource::~YamlParameterSource() = default;
YamlParameterSource::YamlParameterSource(YamlParameterSource&&) noexcept = default;

bool YamlParameterSource::lookup(const std::string& key, YAML::Node* node) const {
  if (!root_) return false;
  YAML::Node current;
  current.reset(*root_);  // assignment would write into the tree; reset re-points the handle
  std::stringstream parts(key);
  std::string part;
  while (std::getline(parts, part, '/')) {
    if (part.empty()) continue;
    if (!current.IsMap()) return false;
    const YAML::Node next = static_cast<const YAML::Node&>(current)[part];
    if (!next.IsDefined() || next.IsNull()) return false;
    current.reset(next);
  }
  node->reset(current);
  return true;
}

namespace {
void collectKeys(const YAML::Node& node, const std::string& prefix,
                 std::vector<std::string>* keys) {
  if (!node.IsMap()) {
    if (!prefix.empty() && !node.IsNull()) keys->push_back(prefix);
    return;
  }
  for (const auto& entry : node) {
    const std::string name = entry.first.as<std::string>();
    collectKeys(entry.second, prefix.empty() ? name : prefix + "/" + name, keys);
  }
}
}  // namespace

std::vector<std::string> YamlParameterSource::keys() const {
  std::vector<std::string> keys;
  if (root_) collectKeys(*root_, "", &keys);
  std::sort(keys.begin(), keys.end());
  return keys;
}

bool YamlParameterSource::has(const std::string& key) const {
  YAML::Node node;
  return lookup(key, &node);
}

namespace {
template <typename T>
bool convertScalar(const YAML::Node& node, T* value) {
  if (!node.IsScalar()) return false;
  try {
    *value = node.as<T>();
    return true;
  } catch (const YAML::Exception&) {
    return false;
  }
}
}  // namespace

bool YamlParameterSource::getDouble(const std::string& key, double* value) const {
  YAML::Node node;
  return lookup(key, &node) && convertScalar(node, value);
}
bool YamlParameterSource::getInt(const std::string& key, int* value) const {
  YAML::Node node;
  return lookup(key, &node) && convertScalar(node, value);
}
bool YamlParameterSource::getBool(const std::string& key, bool* value) const {
  YAML::Node node;
  return lookup(key, &node) && convertScalar(node, value);
}
bool YamlParameterSource::getString(const std::string& key, std::string* value) const {
  YAML::Node node;
  return lookup(key, &node) && convertScalar(node, value);
}

}  // namespace ekf_vislam
