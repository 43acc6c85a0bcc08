// Reads options from a ParameterSource key by key, checking each value's type and remembering
// the first error (one line naming the source and the key). Absent keys keep their values. Shared
// by the option parsers of the estimator and the stereo tracker. No ROS.
#pragma once

#include "ekf_vislam/core/option_table.h"
#include "ekf_vislam/core/parameter_source.h"

#include <cmath>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace ekf_vislam {

class OptionReader {
 public:
  OptionReader(const ParameterSource& source, std::string* error)
      : source_(source), error_(error) {}
  bool ok() const { return ok_; }

  void number(const std::string& key, double* value) {
    if (!ok_ || !source_.has(key)) return;
    if (!source_.getDouble(key, value) || !std::isfinite(*value)) fail(key, "a finite number");
  }
  void integer(const std::string& key, int* value) {
    if (!ok_ || !source_.has(key)) return;
    if (!source_.getInt(key, value)) fail(key, "an integer");
  }
  void flag(const std::string& key, bool* value) {
    if (!ok_ || !source_.has(key)) return;
    if (!source_.getBool(key, value)) fail(key, "true or false");
  }
  template <typename Enum>
  void choice(const std::string& key, Enum* value,
              std::initializer_list<std::pair<const char*, Enum>> names) {
    readChoice(key, value, names);
  }

  // The key-table visitor interface (option_table.h): the bound is checked by OptionValidator.
  void number(const char* key, double& value, Bound) { number(std::string(key), &value); }
  void integer(const char* key, int& value, Bound) { integer(std::string(key), &value); }
  void flag(const char* key, bool& value) { flag(std::string(key), &value); }
  void text(const char* key, std::string& value) {
    if (!ok_ || !source_.has(key)) return;
    if (!source_.getString(key, &value)) fail(key, "a string");
  }
  bool has(const std::string& key) const { return source_.has(key); }
  template <typename Enum, size_t N>
  void choice(const char* key, Enum& value, const EnumNames<Enum, N>& names) {
    readChoice(key, &value, names);
  }

  /// Records "'key' must be <expected>" as the error unless one is already there.
  void fail(const std::string& key, const std::string& expected) {
    if (!ok_) return;
    ok_ = false;
    if (error_ != nullptr) *error_ = source_.describe() + ": '" + key + "' must be " + expected;
  }

 private:
  /// names: (name, value) pairs; an unknown name fails listing them all.
  template <typename Enum, typename Names>
  void readChoice(const std::string& key, Enum* value, const Names& names) {
    if (!ok_ || !source_.has(key)) return;
    std::string text;
    if (source_.getString(key, &text)) {
      for (const auto& [name, e] : names) {
        if (text == name) {
          *value = e;
          return;
        }
      }
    }
    std::string expected;
    for (const auto& [name, e] : names)
      expected += (expected.empty() ? "" : " | ") + std::string(name);
    fail(key, "one of " + expected);
  }

  const ParameterSource& source_;
  std::string* error_;
  bool ok_ = true;
};

/// Reads the keys of a table (a generic callable table(options, visitor), option_table.h) from
/// `source` into *options, then checks every bound and extra_checks(options, &validator) (rules
/// a bound cannot say). False with *error naming the source and the key; *options is then
/// unchanged.
template <typename Options, typename Table, typename ExtraChecks>
bool readOptionTable(const ParameterSource& source, const Table& table, Options* options,
                     std::string* error, const ExtraChecks& extra_checks) {
  OptionReader reader(source, error);
  Options o = *options;
  table(o, reader);
  if (!reader.ok()) return false;
  OptionValidator validator;
  table(static_cast<const Options&>(o), validator);
  extra_checks(static_cast<const Options&>(o), &validator);
  if (!validator.error().empty()) {
    if (error != nullptr) *error = source.describe() + ": " + validator.error();
    return false;
  }
  *options = o;
  return true;
}

template <typename Options, typename Table>
bool readOptionTable(const ParameterSource& source, const Table& table, Options* options,
                     std::string* error) {
  return readOptionTable(source, table, options, error, [](const Options&, OptionValidator*) {});
}

/// Every key of a table, from default-constructed options.
template <typename Options, typename Table>
std::vector<OptionKeyList::Key> optionTableKeys(const Table& table) {
  const Options defaults;
  OptionKeyList list;
  table(defaults, list);
  return list.keys();
}

/// "group: key=value ..." lines of a table's values.
template <typename Options, typename Table>
std::string describeOptionTable(const Options& options, const Table& table) {
  OptionDescriber describer;
  table(options, describer);
  return describer.text();
}

}  // namespace ekf_vislam
