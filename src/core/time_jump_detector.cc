#include "ekf_vislam/core/time_jump_detector.h"

#include <algorithm>
#include <limits>

namespace ekf_vislam {

TimeJumpDetector::TimeJumpDetector(double threshold, int streams)
    : threshold_(threshold), newest_(static_cast<size_t>(std::max(streams, 1))) {
  reset();
}

bool TimeJumpDetector::jumpedBack(int stream, double stamp) {
  const auto k = static_cast<size_t>(std::clamp(stream, 0, static_cast<int>(newest_.size()) - 1));
  // Before a stream's first stamp its newest is -inf: no jump, and the stamp becomes the newest.
  const bool jumped = threshold_ > 0.0 && stamp < newest_[k] - threshold_;
  if (jumped) {
    last_jump_ = newest_[k] - stamp;
    reset();
  }
  newest_[k] = std::max(newest_[k], stamp);
  return jumped;
}

void TimeJumpDetector::reset() {
  std::fill(newest_.begin(), newest_.end(), -std::numeric_limits<double>::infinity());
}

}  // namespace ekf_vislam
