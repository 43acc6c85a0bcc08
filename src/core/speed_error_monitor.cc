#include "ekf_vislam/core/speed_error_monitor.h"

#include <cmath>
#include <limits>

namespace ekf_vislam {

void SpeedErrorMonitor::add(double score, double information) {
  if (!(information > 0.0) || !std::isfinite(score) || !std::isfinite(information)) return;
  score_ += score;
  information_ += information;
  ++updates_;
}

double SpeedErrorMonitor::scaleError() const {
  return information_ > 0.0 ? score_ / information_ : 0.0;
}

double SpeedErrorMonitor::whiteSigma() const {
  return information_ > 0.0 ? 1.0 / std::sqrt(information_)
                            : std::numeric_limits<double>::infinity();
}

}  // namespace ekf_vislam
