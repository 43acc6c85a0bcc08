// Prediction of the filter state with a body-frame twist: the twist correction (bias, twist
// rotation, vehicle prior), its noise, the covariance propagation and the road tilt's
// Gauss-Markov step. No ROS.
#pragma once

#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/travel_direction_estimator.h"
#include "ekf_vislam/core/twist_noise_estimator.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/velocity_reference.h"
#include "ekf_vislam/core/vislam_options.h"

#include <cmath>

namespace ekf_vislam {

class Propagator {
 public:
  /// Twists slower than this (m/s along x) do not show the direction of travel.
  static constexpr double kTravelMinSpeed = 1.0;

  explicit Propagator(const VislamOptions& options)
      : options_(&options),
        noise_estimator_(options.noise.twist_noise_window, options.noise.twist_noise_min_samples),
        travel_direction_(kTravelMinSpeed) {}

  /// Every accepted twist, in stamp order: feeds the online noise estimate and the direction of
  /// travel.
  void observeTwist(const TwistData& twist) {
    noise_estimator_.add(twist);
    travel_direction_.add(twist.v_imu);
    speed_sum_ += std::abs(twist.v_imu.x());
    ++speed_samples_;
    velocity_reference_.add(twist.v_imu, sample_period_);
  }
  /// Forgets the noise estimate, the direction of travel and the velocity reference (a full
  /// filter reset starts them again).
  void resetTwistEstimates() {
    noise_estimator_ = TwistNoiseEstimator(options_->noise.twist_noise_window,
                                           options_->noise.twist_noise_min_samples);
    travel_direction_ = TravelDirectionEstimator(kTravelMinSpeed);
    velocity_reference_.reset();
    speed_sum_ = 0.0;
    speed_samples_ = 0;
  }
  /// Where the twist travels in its own frame (the vehicle prior assumes along x).
  const TravelDirectionEstimator& travelDirection() const { return travel_direction_; }
  /// Mean forward speed |v_x| (m/s) of the twist samples observed, and their number.
  double meanSpeed() const {
    return speed_samples_ > 0 ? speed_sum_ / static_cast<double>(speed_samples_) : 0.0;
  }
  size_t speedSamples() const { return speed_samples_; }
  /// Noise densities of a twist without its own covariance (m/s/sqrt(Hz), rad/s/sqrt(Hz)): the
  /// online estimate once it is ready (noise/estimate_twist_noise), before that the configured
  /// ones, or the few samples' estimate where they reject the configured one as too small.
  double linearNoiseDensity() const;
  double angularNoiseDensity() const;

  /// Period of the twist samples (time since the previous twist): the message covariance is per
  /// sample, the configured noise a density.
  void setSamplePeriod(double period) { sample_period_ = period; }

  /// Moves the state over dt with `twist` (sample k+1 drives [t_k, t_k+1]): the mean by
  /// T(k+1) = T(k) exp(dt u^), u the corrected twist; the covariance with the process noise
  /// times noise_scale (a twist gap), the auxiliary states' random walks, and in SLAM mode the
  /// landmarks' invariant errors moving with the pose error.
  void predict(double dt, const TwistData& twist, double noise_scale, FilterState* state) const;
  /// Moves the state over dt at rest (standstill/): the pose and its covariance stay, the
  /// auxiliary states' random walks go on.
  void holdStill(double dt, FilterState* state) const;

  /// u_true = G R_m (u_measured - b) for the current estimates (G: vehicle prior gains).
  Vector6d correctedTwist(const FilterState& state, const TwistData& twist) const;
  /// Noise density of the corrected twist in the IMU frame (process noise W = density * dt):
  /// from the message's covariance when it has one (noise/use_message_covariance), else from
  /// noise/linear_velocity_noise and angular_velocity_noise; reduced by the vehicle prior.
  Matrix6d noiseDensity(const FilterState& state, const TwistData& twist) const;
  /// Covariance of one corrected twist sample [v; w] (density / period, plus the estimated bias
  /// and speed scale's variances).
  Matrix6d sampleCovariance(const FilterState& state, const TwistData& twist) const;
  /// d u / d (bias, twist rotation), 6 x aux (calibration columns zero), u = correctedTwist.
  Eigen::MatrixXd twistJacobian(const FilterState& state, const TwistData& twist,
                                const Vector6d& u) const;

 private:
  /// Before the online estimate is ready, the configured density is widened to the estimate
  /// only where the samples so far reject it at this probability (a test per group and sample).
  static constexpr double kEarlyNoiseTestProbability = 0.999;
  /// The density of one part of the twist: configured, estimated (sample_sigma per sample) when
  /// ready, before that the larger of the two where the samples reject the configured one.
  double onlineDensity(double configured, bool ready, double sample_sigma,
                       bool rejects_configured) const;
  /// Per-component factor of the vehicle prior on u = [v; w] (1 where there is none).
  Vector6d velocityPriorGain(const FilterState& state, const TwistData& twist) const;
  /// v_ref - b_v: what the speed scale multiplies (velocity_reference.h).
  Eigen::Vector3d scaleReference(const FilterState& state, const TwistData& twist) const;
  /// d (corrected velocity) / d k = Gv R_m (v_ref - b_v).
  Eigen::Vector3d speedScaleJacobian(const FilterState& state, const TwistData& twist) const;
  /// (v - b_v) + k (v_ref - b_v), the twist's velocity with bias and speed scale applied
  /// (twist frame).
  Eigen::Vector3d scaledVelocity(const FilterState& state, const TwistData& twist) const;
  bool usesMessageCovariance(const TwistData& twist) const;
  /// The message's per-sample covariance in the IMU frame times the sample period.
  Matrix6d messageDensity(const FilterState& state, const TwistData& twist) const;
  /// The road tilt's Gauss-Markov step over `distance` m travelled (vehicle/).
  void propagateRoadTilt(double distance, FilterState* state) const;
  /// The variances the random walks add over dt, per auxiliary row (auxDim; tilt rows 0).
  Eigen::VectorXd randomWalkVariances(double dt, const StateLayout& layout) const;
  double period() const { return std::max(1e-3, sample_period_); }

  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
  TwistNoiseEstimator noise_estimator_;
  /// Where the speed scale's Jacobian is taken (velocity_reference.h).
  VelocityReference velocity_reference_;
  TravelDirectionEstimator travel_direction_;
  double speed_sum_ = 0.0;  ///< sum of |v_x| over the samples observed (m/s)
  size_t speed_samples_ = 0;
  double sample_period_ = 0.1;
};

}  // namespace ekf_vislam
