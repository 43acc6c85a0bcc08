#include "ekf_vislam/core/velocity_reference.h"

#include <algorithm>

namespace ekf_vislam {

void VelocityReference::add(const Eigen::Vector3d& v, double period) {
  if (!v.allFinite() || !(period >= 0.0)) return;
  if (has_latest_) {
    // The latest sample joins the mean with its own period's weight.
    const double weight = std::min(1.0, latest_period_ / kTimeConstant);
    mean_ = has_mean_ ? Eigen::Vector3d((1.0 - weight) * mean_ + weight * latest_) : latest_;
    has_mean_ = true;
  }
  latest_ = v;
  latest_period_ = period;
  has_latest_ = true;
}

}  // namespace ekf_vislam
