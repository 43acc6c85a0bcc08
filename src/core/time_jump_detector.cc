#include "ekf_vislam/core/time_jump_detector.h"

#include <algorithm>

namespace ekf_vislam {

TimeJumpDetector::TimeJumpDetector(double threshold, int streams)
    : threshold_(threshold),
      newest_(static_cast<size_t>(std::max(streams, 1)), 0.0),
      has_newest_(newest_.size(), false) {}

bool TimeJumpDetector::jumpedBack(int stream, double stamp) {
  const auto k = static_cast<size_t>(std::clamp(stream, 0, static_cast<int>(newest_.size()) - 1));
  const bool jumped = threshold_ > 0.0 && has_newest_[k] && stamp < newest_[k] - threshold_;
  if (jumped) {
    last_jump_ = newest_[k] - stamp;
    reset();
  }
  if (!has_newest_[k] || stamp > newest_[k]) {
    newest_[k] = stamp;
    has_newest_[k] = true;
  }
  return jumped;
}

void TimeJumpDetector::reset() {
  std::fill(newest_.begin(), newest_.end(), 0.0);
  std::fill(has_newest_.begin(), has_newest_.end(), false);
}

}  // namespace ekf_vislam
