#include "ekf_vislam/tracker/feature_columns.h"

#include <algorithm>
#include <functional>
#include <map>
#include <queue>
#include <utility>

namespace ekf_vislam {

namespace {

struct Span {
  size_t first = 0, last = 0;
};

/// Each id's first and last frame, by id.
std::map<uint32_t, Span> idSpans(const std::vector<StereoFrame>& frames) {
  std::map<uint32_t, Span> spans;
  for (size_t k = 0; k < frames.size(); ++k) {
    for (const TrackedFeature& f : frames[k].features) {
      auto [it, added] = spans.emplace(f.id, Span{k, k});
      if (!added) it->second.last = k;
    }
  }
  return spans;
}

}  // namespace

FeatureColumns assignFeatureColumns(const std::vector<StereoFrame>& frames, size_t reuse_gap) {
  const std::map<uint32_t, Span> spans = idSpans(frames);
  FeatureColumns result;
  if (reuse_gap == 0) {
    for (const auto& [id, span] : spans) result.column_of_id[id] = result.columns++;
    return result;
  }
  std::vector<std::pair<uint32_t, Span>> by_first(spans.begin(), spans.end());
  std::stable_sort(by_first.begin(), by_first.end(),
                   [](const auto& a, const auto& b) { return a.second.first < b.second.first; });
  // (first frame a column may be taken again, column), earliest first.
  using FreeColumn = std::pair<size_t, size_t>;
  std::priority_queue<FreeColumn, std::vector<FreeColumn>, std::greater<FreeColumn>> free;
  for (const auto& [id, span] : by_first) {
    size_t column = result.columns;
    if (!free.empty() && free.top().first <= span.first) {
      column = free.top().second;
      free.pop();
    } else {
      ++result.columns;
    }
    result.column_of_id[id] = column;
    free.emplace(span.last + 1 + reuse_gap, column);
  }
  return result;
}

}  // namespace ekf_vislam
