// Online estimate of the white noise of the twist input, from the twist samples alone. The
// second difference u(k+1) - 2 u(k) + u(k-1) of evenly spaced samples carries 6 sigma^2 of white
// noise and only dt^2 times the jerk of the true motion, so the median of its square over a
// window, divided by 6 x 0.4549 (the median of chi-square with 1 dof), is the per-sample noise
// variance, robust to manoeuvres and outliers. Linear and angular axes are pooled. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <deque>
#include <optional>

namespace ekf_vislam {

class TwistNoiseEstimator {
 public:
  /// window: second differences the estimate covers; min_samples: second differences before it
  /// is used (each needs three evenly spaced samples).
  TwistNoiseEstimator(int window, int min_samples);

  /// Adds a twist (in stamp order). A sample whose period differs from the previous one by more
  /// than half restarts the differences (a gap or a change of rate).
  void add(const TwistData& twist);

  bool ready() const { return linear_.size() >= 3 * static_cast<size_t>(min_samples_); }
  /// Per-sample standard deviation of each linear (m/s) and angular (rad/s) component.
  double linearSigma() const { return linear_sigma_; }
  double angularSigma() const { return angular_sigma_; }

 private:
  void push(std::deque<double>* squares, const Eigen::Vector3d& second_difference);
  static double sigmaOf(const std::deque<double>& squares);

  int window_;
  int min_samples_;
  std::optional<TwistData> previous_;
  std::optional<TwistData> before_previous_;
  std::deque<double> linear_;  ///< squared second differences, 3 per sample
  std::deque<double> angular_;
  double linear_sigma_ = 0.0;
  double angular_sigma_ = 0.0;
};

}  // namespace ekf_vislam
