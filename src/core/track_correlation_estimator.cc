#include "ekf_vislam/core/track_correlation_estimator.h"

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

TrackCorrelationEstimator::TrackCorrelationEstimator(int window, int min_pairs,
                                                     double max_correlation)
    : forget_(1.0 - 1.0 / std::max(1, window)),
      min_pairs_(std::max(1, min_pairs)),
      max_correlation_(max_correlation) {}

void TrackCorrelationEstimator::add(const Eigen::VectorXd& residual,
                                    const Eigen::VectorXd& previous_residual) {
  if (residual.size() != previous_residual.size() || !residual.allFinite() ||
      !previous_residual.allFinite()) {
    return;
  }
  cross_ = forget_ * cross_ + residual.dot(previous_residual);
  current_ = forget_ * current_ + residual.squaredNorm();
  previous_ = forget_ * previous_ + previous_residual.squaredNorm();
  ++pairs_;
}

double TrackCorrelationEstimator::correlation() const {
  const double norm = std::sqrt(current_ * previous_);
  if (!ready() || !(norm > 0.0)) return 0.0;
  return std::clamp(cross_ / norm, 0.0, max_correlation_);
}

double TrackCorrelationEstimator::varianceFactor() const {
  const double rho = correlation();
  return (1.0 + rho) / (1.0 - rho);
}

}  // namespace ekf_vislam
