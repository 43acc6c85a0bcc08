#include "ekf_vislam/core/parameter_source.h"

#include <algorithm>
#include <sstream>

namespace ekf_vislam {

namespace {

/// Levenshtein distance: how many single-character edits turn a into b.
size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::vector<std::string> unknownKeys(const ParameterSource& source,
                                     const std::vector<std::string>& known,
                                     const std::vector<std::string>& known_groups) {
  std::vector<std::string> unknown;
  for (const std::string& key : source.keys()) {
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    const bool in_group =
        std::any_of(known_groups.begin(), known_groups.end(),
                    [&](const std::string& group) { return key.rfind(group, 0) == 0; });
    if (!in_group) unknown.push_back(key);
  }
  return unknown;
}

std::string describeUnknownKeys(const std::vector<std::string>& unknown,
                                const std::vector<std::string>& known) {
  if (unknown.empty()) return "";
  std::ostringstream text;
  text << "unknown key" << (unknown.size() > 1 ? "s" : "") << " ignored:";
  for (size_t i = 0; i < unknown.size(); ++i) {
    text << (i == 0 ? " " : ", ") << unknown[i];
    const auto nearest = std::min_element(
        known.begin(), known.end(), [&](const std::string& a, const std::string& b) {
          return editDistance(unknown[i], a) < editDistance(unknown[i], b);
        });
    // Only a near miss is worth naming (a third of the key's length at most).
    if (nearest != known.end() && 3 * editDistance(unknown[i], *nearest) <= unknown[i].size()) {
      text << " (" << *nearest << "?)";
    }
  }
  return text.str();
}

}  // namespace ekf_vislam
