// Where a ground vehicle's twist travels in its own frame. The vehicle prior
// (vehicle/*_velocity_sigma) holds the lateral (y) and vertical (z) velocity near zero: right for
// a twist frame whose x is the vehicle's travel, wrong for one mounted at an angle to it (a
// camera's axes, a tilted IMU), where it removes a part of the true velocity proportional to the
// speed. The least-squares slopes of y and z against x over every sample that moves estimate
// that mounting angle: white noise averages out, and so does the body's pitching on hills and
// under braking (30 s windows of the KITTI course twists swing by up to 3 degrees, their whole
// drives stay within 0.7). No ROS.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <cstddef>

namespace ekf_vislam {

class TravelDirectionEstimator {
 public:
  /// Samples slower than min_speed (|x| in m/s) are left out: there the direction is lost in
  /// the noise.
  explicit TravelDirectionEstimator(double min_speed) : min_speed_(min_speed) {}

  /// Adds one body velocity (twist frame, m/s).
  void add(const Eigen::Vector3d& v);

  size_t samples() const { return samples_; }
  /// Angles (rad) of the travel from x: towards +y (yaw) and towards +z (pitch); 0 without samples.
  double yaw() const;
  double pitch() const;
  /// The same in degrees, the unit the diagnostics, stats.json and the warning report.
  double yawDegrees() const { return yaw() * 180.0 / M_PI; }
  double pitchDegrees() const { return pitch() * 180.0 / M_PI; }

 private:
  double min_speed_;
  size_t samples_ = 0;
  Eigen::Vector3d sums_ = Eigen::Vector3d::Zero();  ///< sum of x x, x y, x z over the samples
};

}  // namespace ekf_vislam
