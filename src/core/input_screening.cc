#include "ekf_vislam/core/input_screening.h"

#include <cmath>
#include <sstream>

namespace ekf_vislam {

std::optional<Counter> InputScreening::checkTwist(const TwistData& twist, std::string* why) const {
  if (!std::isfinite(twist.stamp) || !twist.v_imu.allFinite() || !twist.w_imu.allFinite()) {
    *why = "twist with NaN/Inf rejected";
    return Counter::kTwistNonFinite;
  }
  if (twist.v_imu.norm() > options_->limits.max_linear_speed ||
      twist.w_imu.norm() > options_->limits.max_angular_speed) {
    std::ostringstream text;
    text << "implausible twist rejected (|v| = " << twist.v_imu.norm()
         << " m/s, |w| = " << twist.w_imu.norm()
         << " rad/s; limits/max_linear_speed = " << options_->limits.max_linear_speed
         << ", limits/max_angular_speed = " << options_->limits.max_angular_speed << ")";
    *why = text.str();
    return Counter::kTwistImplausible;
  }
  return std::nullopt;
}

std::optional<Counter> InputScreening::checkAccelerometer(const AccelerometerData& sample,
                                                          std::string* why) const {
  if (!std::isfinite(sample.stamp) || !sample.f_imu.allFinite() || !sample.covariance.allFinite()) {
    *why = "accelerometer sample with NaN/Inf rejected";
    return Counter::kAccelNonFinite;
  }
  const double g = options_->gravity.magnitude;
  const double norm = sample.f_imu.norm();
  if (norm < 0.3 * g || norm > 4.0 * g) {
    std::ostringstream text;
    text << "implausible accelerometer sample rejected (|f| = " << norm
         << " m/s^2; at rest an accelerometer reads " << g
         << "): a message without accelerometer data, or in other units";
    *why = text.str();
    return Counter::kAccelImplausible;
  }
  return std::nullopt;
}

std::optional<Counter> InputScreening::checkObservation(const StereoObservation& f,
                                                        const StereoCamera& camera) const {
  if (!std::isfinite(f.u_left) || !std::isfinite(f.v_left) || !std::isfinite(f.u_right) ||
      !std::isfinite(f.v_right)) {
    return Counter::kObsNonFinite;
  }
  if (!camera.inImage(f.u_left, f.v_left) || !camera.inImage(f.u_right, f.v_right)) {
    return Counter::kObsOutsideImage;
  }
  if (std::fabs(f.v_left - f.v_right) > options_->limits.max_row_difference_px) {
    return Counter::kObsRowMismatch;
  }
  if (f.u_left - f.u_right < options_->landmarks.min_disparity_px) return Counter::kObsDisparity;
  return std::nullopt;
}

bool InputScreening::screen(const StereoObservation& f, const StereoCamera& camera,
                            EstimatorStats* stats, FeedResult* result) const {
  const std::optional<Counter> reason = checkObservation(f, camera);
  if (!reason) return true;
  stats->increment(*reason);
  ++result->observations_rejected;
  return false;
}

}  // namespace ekf_vislam
