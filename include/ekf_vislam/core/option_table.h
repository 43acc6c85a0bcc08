// One key table drives parsing, validation and the start-up description of an options struct.
// The table is a function template that lists every key once, with the field it fills and the
// range it must lie in:
//
//   template <typename Options, typename Visitor>
//   void visitFooOptions(Options& o, Visitor& v) {
//     v.number("noise/pixel_sigma", o.noise.pixel_sigma, Bound::kPositive);
//     v.flag("noise/merge_stereo_rows", o.noise.merge_stereo_rows);
//     v.choice("mode", o.mode, kModeNames);
//   }
//
// and each visitor below does one job with it: OptionReader (option_reader.h) parses,
// OptionValidator checks the ranges, OptionDescriber writes "group: key=value ..." lines and
// OptionKeyList collects the keys (for tests: every key documented, every bound enforced). No ROS.
#pragma once

#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace ekf_vislam {

/// The range a numeric option must lie in.
enum class Bound {
  kAny,           ///< any finite value
  kPositive,      ///< > 0
  kNonNegative,   ///< >= 0
  kOpenUnit,      ///< in (0, 1)
  kUnitFraction,  ///< in (0, 1]
  kCorrelation,   ///< in [0, 1)
  kAtLeastOne,    ///< >= 1
};

/// "must be positive", ... (empty for kAny).
const char* boundDescription(Bound bound);
bool withinBound(double value, Bound bound);
/// A value just outside the bound (for tests), or NaN for kAny.
double valueOutside(Bound bound);

/// Names of an enum option's values, in the order they are documented.
template <typename Enum, size_t N>
using EnumNames = std::array<std::pair<const char*, Enum>, N>;

template <typename Enum, size_t N>
const char* enumName(const EnumNames<Enum, N>& names, Enum value) {
  for (const auto& [name, e] : names) {
    if (e == value) return name;
  }
  return "unknown";
}

/// Checks every numeric key against its bound; remembers the first violation as
/// "'key' must be positive (value)".
class OptionValidator {
 public:
  void number(const char* key, double value, Bound bound) { check(key, value, bound); }
  void integer(const char* key, int value, Bound bound) { check(key, value, bound); }
  void flag(const char*, bool) {}
  void text(const char*, const std::string&) {}
  template <typename Enum, size_t N>
  void choice(const char*, Enum, const EnumNames<Enum, N>&) {}

  /// Empty when every key is within its bound.
  const std::string& error() const { return error_; }
  /// Records a cross-key violation (the first one wins).
  void fail(const std::string& why) {
    if (error_.empty()) error_ = why;
  }

 private:
  void check(const char* key, double value, Bound bound);
  std::string error_;
};

/// "group: key=value key=value" lines, one per key group (the part before the last '/').
class OptionDescriber {
 public:
  void number(const char* key, double value, Bound) { add(key, toText(value)); }
  void integer(const char* key, int value, Bound) { add(key, std::to_string(value)); }
  void flag(const char* key, bool value) { add(key, value ? "true" : "false"); }
  void text(const char* key, const std::string& value) {
    add(key, value.empty() ? "(none)" : value);
  }
  template <typename Enum, size_t N>
  void choice(const char* key, Enum value, const EnumNames<Enum, N>& names) {
    add(key, enumName(names, value));
  }
  std::string text() const { return out_.str(); }

 private:
  static std::string toText(double value);
  void add(const std::string& key, const std::string& value);
  std::ostringstream out_;
  std::string group_;
  bool first_ = true;
  bool line_empty_ = true;
};

/// Every key of a table, with its kind and bound.
class OptionKeyList {
 public:
  enum class Kind { kNumber, kInteger, kFlag, kChoice, kText };
  struct Key {
    std::string name;
    Kind kind;
    Bound bound;
  };
  void number(const char* key, double, Bound bound) {
    keys_.push_back({key, Kind::kNumber, bound});
  }
  void integer(const char* key, int, Bound bound) { keys_.push_back({key, Kind::kInteger, bound}); }
  void flag(const char* key, bool) { keys_.push_back({key, Kind::kFlag, Bound::kAny}); }
  void text(const char* key, const std::string&) {
    keys_.push_back({key, Kind::kText, Bound::kAny});
  }
  template <typename Enum, size_t N>
  void choice(const char* key, Enum, const EnumNames<Enum, N>&) {
    keys_.push_back({key, Kind::kChoice, Bound::kAny});
  }
  const std::vector<Key>& keys() const { return keys_; }

 private:
  std::vector<Key> keys_;
};

/// The names of `keys` ("noise/pixel_sigma", ...), appended to `names`.
inline void appendKeyNames(const std::vector<OptionKeyList::Key>& keys,
                           std::vector<std::string>* names) {
  for (const OptionKeyList::Key& key : keys) names->push_back(key.name);
}

}  // namespace ekf_vislam
