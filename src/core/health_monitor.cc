#include "ekf_vislam/core/health_monitor.h"

#include <cmath>
#include <sstream>

namespace ekf_vislam {

bool HealthMonitor::diverged(int candidates, int disagreeing, double position_sigma,
                             std::string* why) {
  if (candidates >= 10 && disagreeing > options_->health.rejected_fraction * candidates) {
    ++consecutive_rejected_frames_;
  } else {
    consecutive_rejected_frames_ = 0;
  }
  std::ostringstream text;
  if (!std::isfinite(position_sigma) || position_sigma > options_->health.max_position_sigma) {
    text << "pose covariance blew up (position sigma " << position_sigma
         << " m > health/max_position_sigma)";
  } else if (consecutive_rejected_frames_ >= options_->health.max_rejected_frames) {
    text << consecutive_rejected_frames_ << " consecutive frames with most observations gated";
  } else {
    return false;
  }
  consecutive_rejected_frames_ = 0;
  *why = text.str();
  return true;
}

}  // namespace ekf_vislam
