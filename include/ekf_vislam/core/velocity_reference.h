// The twist's recent velocity without its latest sample: an exponential mean (time constant
// kTimeConstant) of the samples before the latest one. The speed scale state's Jacobian is
// taken there instead of at the measured velocity, whose noise would otherwise bias the scale
// towards zero (errors in variables: with 0.5 m/s of noise at 0.5-1.5 m/s, a right speed read
// 14.7-17.6 % too fast; doc/estimator.md, Twist speed scale). No ROS.
#pragma once

#include <Eigen/Core>

namespace ekf_vislam {

class VelocityReference {
 public:
  /// s: long enough to average a twist's white noise, short enough to follow a vehicle's
  /// speed changes.
  static constexpr double kTimeConstant = 1.0;

  /// One accepted sample (m/s, any frame) that covers `period` s, in stamp order. A non-finite
  /// one is left out.
  void add(const Eigen::Vector3d& v, double period);
  /// The mean of the samples before the latest one; until two samples came, `fallback`.
  Eigen::Vector3d value(const Eigen::Vector3d& fallback) const {
    return has_mean_ ? mean_ : fallback;
  }
  void reset() { *this = VelocityReference(); }

 private:
  Eigen::Vector3d mean_ = Eigen::Vector3d::Zero();    ///< of the samples before latest_
  Eigen::Vector3d latest_ = Eigen::Vector3d::Zero();  ///< the latest sample
  double latest_period_ = 0.0;
  bool has_latest_ = false;
  bool has_mean_ = false;
};

}  // namespace ekf_vislam
