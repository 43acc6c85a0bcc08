#include "ekf_vislam/tracker/klt_back_check.h"

#include <algorithm>

namespace ekf_vislam {

KltSettings backCheckSettings(const KltSettings& forward, int levels) {
  KltSettings back = forward;
  back.levels = std::min(forward.levels, std::max(levels, 0));
  return back;
}

std::vector<uint8_t> backCheck(const std::vector<cv::Mat>& moved_pyramid,
                               const std::vector<cv::Mat>& origin_pyramid,
                               const std::vector<cv::Point2f>& moved,
                               const std::vector<cv::Point2f>& origin,
                               const std::vector<size_t>& candidates, const KltSettings& klt,
                               double tolerance_px) {
  std::vector<uint8_t> passed(origin.size(), 0);
  if (candidates.empty()) return passed;
  std::vector<cv::Point2f> from(candidates.size()), back(candidates.size());
  for (size_t j = 0; j < candidates.size(); ++j) {
    from[j] = moved[candidates[j]];
    back[j] = origin[candidates[j]];
  }
  std::vector<uint8_t> status;
  trackPyramidalKlt(moved_pyramid, origin_pyramid, from, &back, &status, klt);
  for (size_t j = 0; j < candidates.size(); ++j) {
    const size_t i = candidates[j];
    passed[i] = status[j] && cv::norm(back[j] - origin[i]) <= tolerance_px;
  }
  return passed;
}

}  // namespace ekf_vislam
