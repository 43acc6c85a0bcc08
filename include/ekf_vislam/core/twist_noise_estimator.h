// Online estimate of the white noise of the twist input, from the twist samples alone. The
// second difference u(k+1) - 2 u(k) + u(k-1) of evenly spaced samples carries 6 sigma^2 of white
// noise and only dt^2 times the jerk of the true motion, so the median of its square over a
// window, divided by 6 x 0.4549 (the median of chi-square with 1 dof), is the per-sample noise
// variance, robust to manoeuvres and outliers. Linear and angular axes are pooled. A component that
// holds one value over the three samples (a wheel odometry at rest reads exactly 0) says nothing
// of the noise and is left out, so a stop does not talk the estimate down to zero. No ROS.
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

  /// Whether enough second differences of the linear (angular) components have come to use
  /// linearSigma() (angularSigma()); each part on its own, as a stream may carry one only.
  bool linearReady() const { return linear_.size() >= minSquares(); }
  bool angularReady() const { return angular_.size() >= minSquares(); }
  /// Per-sample standard deviation of each linear (m/s) and angular (rad/s) component.
  double linearSigma() const { return linear_sigma_; }
  double angularSigma() const { return angular_sigma_; }
  /// Whether the second differences so far reject a per-sample std `sigma` as too small: the
  /// sum of their squares over 6 sigma^2, chi-square with one dof per value under white noise of
  /// that std, beyond its `probability` quantile. A smooth motion adds little to the squares;
  /// a manoeuvre or an outlier can make the test pass, but not the median (linearSigma()).
  bool linearExceeds(double sigma, double probability) const {
    return exceeds(linear_, sigma, probability);
  }
  bool angularExceeds(double sigma, double probability) const {
    return exceeds(angular_, sigma, probability);
  }

 private:
  size_t minSquares() const { return 3 * static_cast<size_t>(min_samples_); }
  // Appends the squared second differences of the components that changed over the three
  // samples (before, previous, now) and drops those beyond the window.
  void push(const Eigen::Vector3d& before, const Eigen::Vector3d& previous,
            const Eigen::Vector3d& now, std::deque<double>* squares);
  static double sigmaOf(const std::deque<double>& squares);
  static bool exceeds(const std::deque<double>& squares, double sigma, double probability);

  int window_;
  int min_samples_;
  std::optional<TwistData> previous_;
  std::optional<TwistData> before_previous_;
  std::deque<double> linear_;  ///< squared second differences, up to 3 per sample
  std::deque<double> angular_;
  double linear_sigma_ = 0.0;
  double angular_sigma_ = 0.0;
};

}  // namespace ekf_vislam
