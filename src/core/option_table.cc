#include "ekf_vislam/core/option_table.h"

#include <limits>

namespace ekf_vislam {

const char* boundDescription(Bound bound) {
  switch (bound) {
    case Bound::kAny: return "";
    case Bound::kPositive: return "must be positive";
    case Bound::kNonNegative: return "must be >= 0";
    case Bound::kOpenUnit: return "must be in (0, 1)";
    case Bound::kUnitFraction: return "must be in (0, 1]";
    case Bound::kCorrelation: return "must be in [0, 1)";
    case Bound::kAtLeastOne: return "must be >= 1";
  }
  return "";
}

bool withinBound(double value, Bound bound) {
  if (!std::isfinite(value)) return false;
  switch (bound) {
    case Bound::kAny: return true;
    case Bound::kPositive: return value > 0.0;
    case Bound::kNonNegative: return value >= 0.0;
    case Bound::kOpenUnit: return value > 0.0 && value < 1.0;
    case Bound::kUnitFraction: return value > 0.0 && value <= 1.0;
    case Bound::kCorrelation: return value >= 0.0 && value < 1.0;
    case Bound::kAtLeastOne: return value >= 1.0;
  }
  return false;
}

double valueOutside(Bound bound) {
  switch (bound) {
    case Bound::kAny: return std::numeric_limits<double>::quiet_NaN();
    case Bound::kPositive: return 0.0;
    case Bound::kNonNegative: return -1.0;
    case Bound::kOpenUnit: return 1.0;
    case Bound::kUnitFraction: return 0.0;
    case Bound::kCorrelation: return 1.0;
    case Bound::kAtLeastOne: return 0.0;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

void OptionValidator::check(const char* key, double value, Bound bound) {
  if (!error_.empty() || withinBound(value, bound)) return;
  std::ostringstream why;
  why << "'" << key << "' " << (bound == Bound::kAny ? "must be finite" : boundDescription(bound))
      << " (" << value << ")";
  error_ = why.str();
}

std::string OptionDescriber::toText(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

void OptionDescriber::add(const std::string& key, const std::string& value) {
  const size_t slash = key.rfind('/');
  const std::string group = slash == std::string::npos ? "" : key.substr(0, slash);
  const std::string name = slash == std::string::npos ? key : key.substr(slash + 1);
  if (first_ || group != group_) {
    if (!first_) out_ << "\n";
    if (!group.empty()) out_ << group << ":";
    group_ = group;
    line_empty_ = group.empty();
    first_ = false;
  }
  out_ << (line_empty_ ? "" : " ") << name << "=" << value;
  line_empty_ = false;
}

}  // namespace ekf_vislam
