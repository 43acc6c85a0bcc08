#include "ekf_vislam/core/consider_error_monitor.h"

#include <cmath>
#include <limits>

namespace ekf_vislam {

void ConsiderErrorMonitor::add(const ConsiderEvidence& evidence) {
  if (!(evidence.information > 0.0) || !std::isfinite(evidence.score) ||
      !std::isfinite(evidence.information)) {
    return;
  }
  score_ += evidence.score;
  information_ += evidence.information;
  ++updates_;
}

double ConsiderErrorMonitor::error() const {
  return information_ > 0.0 ? score_ / information_ : 0.0;
}

double ConsiderErrorMonitor::whiteSigma() const {
  return information_ > 0.0 ? 1.0 / std::sqrt(information_)
                            : std::numeric_limits<double>::infinity();
}

}  // namespace ekf_vislam
