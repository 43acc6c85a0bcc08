#include "ekf_vislam/core/travel_direction_estimator.h"

#include <cmath>

namespace ekf_vislam {

void TravelDirectionEstimator::add(const Eigen::Vector3d& v) {
  if (!v.allFinite() || !(std::abs(v.x()) >= min_speed_)) return;
  sums_ += v.x() * v;
  ++samples_;
}

double TravelDirectionEstimator::yaw() const {
  return samples_ == 0 ? 0.0 : std::atan(sums_.y() / sums_.x());
}

double TravelDirectionEstimator::pitch() const {
  return samples_ == 0 ? 0.0 : std::atan(sums_.z() / sums_.x());
}

}  // namespace ekf_vislam
