#include "ekf_vislam/tracker/frame_rate_limit.h"

namespace ekf_vislam {

bool dueForTracking(double stamp, double last_tracked_stamp, double max_rate_hz) {
  if (max_rate_hz <= 0 || last_tracked_stamp < 0) return true;
  return stamp - last_tracked_stamp >= kRateSlack / max_rate_hz;
}

std::vector<size_t> framesDueForTracking(const std::vector<double>& stamps, double max_rate_hz) {
  std::vector<size_t> due;
  double last = -1;
  for (size_t k = 0; k < stamps.size(); ++k) {
    if (!dueForTracking(stamps[k], last, max_rate_hz)) continue;
    due.push_back(k);
    last = stamps[k];
  }
  return due;
}

}  // namespace ekf_vislam
