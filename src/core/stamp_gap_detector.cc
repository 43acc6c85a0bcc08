#include "ekf_vislam/core/stamp_gap_detector.h"

#include "ekf_vislam/core/median.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace ekf_vislam {

double StampGapDetector::period() const {
  if (static_cast<int>(intervals_.size()) < min_intervals_) return 0.0;
  std::vector<double> intervals(intervals_.begin(), intervals_.end());
  return upperMedian(&intervals);
}

int StampGapDetector::add(double stamp) {
  if (has_last_ && !(stamp > last_)) reset();  // time went back (or stood still)
  int missing = 0;
  if (has_last_) {
    const double interval = stamp - last_;
    const double expected = period();
    if (expected > 0.0 && interval > factor_ * expected) {
      missing = std::max(1, static_cast<int>(std::lround(interval / expected)) - 1);
    } else {
      // Gaps stay out of the period's estimate.
      intervals_.push_back(interval);
      if (static_cast<int>(intervals_.size()) > window_) intervals_.pop_front();
    }
  }
  has_last_ = true;
  last_ = stamp;
  missing_ += static_cast<uint64_t>(missing);
  return missing;
}

std::string StampGapDetector::describeMissing(int missing, double stamp, const char* what) const {
  char text[160];
  std::snprintf(text, sizeof(text),
                "about %d %s(s) missing before %.3f (period %.3f s; %lu so far)", missing, what,
                stamp, period(), static_cast<unsigned long>(missing_));
  return text;
}

void StampGapDetector::reset() {
  has_last_ = false;
  intervals_.clear();
}

}  // namespace ekf_vislam
