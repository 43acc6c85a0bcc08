#include "ekf_vislam/core/propagator.h"

#include "ekf_vislam/core/se3.h"

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

Eigen::Vector3d Propagator::scaleReference(const FilterState& state, const TwistData& twist) const {
  return velocity_reference_.value(twist.v_imu) - state.biasVector().head<3>();
}

Eigen::Vector3d Propagator::speedScaleJacobian(const FilterState& state,
                                               const TwistData& twist) const {
  return velocityPriorGain(state, twist)
      .head<3>()
      .cwiseProduct(state.imu_R_twist * scaleReference(state, twist));
}

Eigen::Vector3d Propagator::scaledVelocity(const FilterState& state, const TwistData& twist) const {
  const Eigen::Vector3d v = twist.v_imu - state.biasVector().head<3>();
  if (state.layout().speed_scale_dim == 0) return v;
  return v + state.speed_scale_error * scaleReference(state, twist);
}

Vector6d Propagator::correctedTwist(const FilterState& state, const TwistData& twist) const {
  Vector6d u;
  u.head<3>() = velocityPriorGain(state, twist)
                    .head<3>()
                    .cwiseProduct(state.imu_R_twist * scaledVelocity(state, twist));
  u.tail<3>() = state.imu_R_twist * (twist.w_imu - state.biasVector().tail<3>());
  return u;
}

Vector6d Propagator::velocityPriorGain(const FilterState& state, const TwistData& twist) const {
  // A measured component (IMU frame) with per-sample variance r fused with a zero-mean prior of
  // variance s^2: mean g * measured, variance g * r, with g = s^2 / (s^2 + r). r is the
  // message's own variance when it carries a covariance (noise/use_message_covariance), else
  // sigma_v^2 / dt (isotropic: rotating by R_m keeps it).
  Vector6d gain = Vector6d::Ones();
  const bool own = usesMessageCovariance(twist);
  const Matrix6d own_density = own ? messageDensity(state, twist) : Matrix6d::Zero();
  const double dt = period();
  const double linear_density = linearNoiseDensity();
  const double r_configured = linear_density * linear_density / dt;
  const double sigmas[2] = {options_->vehicle.lateral_velocity_sigma,
                            options_->vehicle.vertical_velocity_sigma};
  for (int axis = 1; axis <= 2; ++axis) {
    const double r = own ? own_density(axis, axis) / dt : r_configured;
    const double s2 = sigmas[axis - 1] * sigmas[axis - 1];
    if (s2 > 0.0 && r > 0.0) gain(axis) = s2 / (s2 + r);
  }
  return gain;
}

// Per-sample std sigma of a sample covering `period`: density = sigma sqrt(period).
// Before min_samples second differences have come, the few there are may only widen the
// configured density, and only where they reject it (kEarlyNoiseTestProbability): a twist clearly
// noisier than the guess is counted from its first samples (counted too small, its early errors
// would be believed and stay); one as good as the guess or better keeps the guess until the full
// count (more weight on a few early tracks, some of them wrong, costs more than it gains).
double Propagator::linearNoiseDensity() const {
  const double configured = options_->noise.linear_velocity_noise;
  const bool ready = noise_estimator_.linearReady();
  return onlineDensity(configured, ready, noise_estimator_.linearSigma(),
                       !ready && noise_estimator_.linearExceeds(configured / std::sqrt(period()),
                                                                kEarlyNoiseTestProbability));
}

double Propagator::angularNoiseDensity() const {
  const double configured = options_->noise.angular_velocity_noise;
  const bool ready = noise_estimator_.angularReady();
  return onlineDensity(configured, ready, noise_estimator_.angularSigma(),
                       !ready && noise_estimator_.angularExceeds(configured / std::sqrt(period()),
                                                                 kEarlyNoiseTestProbability));
}

double Propagator::onlineDensity(double configured, bool ready, double sample_sigma,
                                 bool rejects_configured) const {
  if (!options_->noise.estimate_twist_noise) return configured;
  const double estimated = sample_sigma * std::sqrt(period());
  if (ready) return estimated;
  return rejects_configured ? std::max(configured, estimated) : configured;
}

bool Propagator::usesMessageCovariance(const TwistData& twist) const {
  return options_->noise.use_message_covariance && twist.hasCovariance();
}

Matrix6d Propagator::messageDensity(const FilterState& state, const TwistData& twist) const {
  Matrix6d R = Matrix6d::Zero();
  R.topLeftCorner<3, 3>() = state.imu_R_twist;
  R.bottomRightCorner<3, 3>() = state.imu_R_twist;
  return period() * R * twist.covariance * R.transpose();
}

Matrix6d Propagator::noiseDensity(const FilterState& state, const TwistData& twist) const {
  const Vector6d gain = velocityPriorGain(state, twist);
  if (usesMessageCovariance(twist)) {
    const Vector6d root = gain.cwiseSqrt();
    return root.asDiagonal() * messageDensity(state, twist) * root.asDiagonal();
  }
  const double linear_density = linearNoiseDensity();
  const double angular_density = angularNoiseDensity();
  const double qv = linear_density * linear_density;
  const double qw = angular_density * angular_density;
  Vector6d q = gain;
  q.head<3>() *= qv;
  q.tail<3>() *= qw;
  return q.asDiagonal();
}

Matrix6d Propagator::sampleCovariance(const FilterState& state, const TwistData& twist) const {
  Matrix6d cov = noiseDensity(state, twist) / period();
  const StateLayout& layout = state.layout();
  const Eigen::MatrixXd S = state.auxCovariance(0);  // the bias block: no deferred step applied
  const int bias = layout.biasRow() - StateLayout::kPoseDim;
  for (int i = 0; i < layout.biasDim(); ++i) {
    for (int j = 0; j < layout.biasDim(); ++j) {
      cov(layout.bias_components[i], layout.bias_components[j]) += S(bias + i, bias + j);
    }
  }
  if (layout.speed_scale_dim > 0) {
    const int k = layout.speedScaleRow() - StateLayout::kPoseDim;
    const Eigen::Vector3d du_dk = speedScaleJacobian(state, twist);
    cov.topLeftCorner<3, 3>() += S(k, k) * du_dk * du_dk.transpose();
  }
  return cov;
}

Eigen::MatrixXd Propagator::twistJacobian(const FilterState& state, const TwistData& twist,
                                          const Vector6d& u) const {
  // u = [Gv R_m ((v - b_v) + k (v_ref - b_v)); R_m (w - b_w)] (Gv: vehicle prior gains, k:
  // speed scale error, v_ref: the velocity reference): du/db = -[(1 + k) Gv R_m; R_m] (bias
  // components), du/dk = [Gv R_m (v_ref - b_v); 0] and du/dtheta = -[Gv (R_m v_s)^; (R_m (w -
  // b_w))^], v_s the scaled velocity.
  const StateLayout& layout = state.layout();
  const int bias_dim = layout.biasDim();
  Eigen::MatrixXd du_daux = Eigen::MatrixXd::Zero(StateLayout::kPoseDim, layout.auxDim());
  const Eigen::Matrix3d Gv = velocityPriorGain(state, twist).head<3>().asDiagonal();
  for (int i = 0; i < bias_dim; ++i) {
    const int c = layout.bias_components[i];
    if (c < 3) {
      du_daux.block<3, 1>(0, i) = -(1.0 + state.speed_scale_error) * Gv * state.imu_R_twist.col(c);
    } else {
      du_daux.block<3, 1>(3, i) = -state.imu_R_twist.col(c - 3);
    }
  }
  if (layout.speed_scale_dim > 0) {
    du_daux.block<3, 1>(0, layout.speedScaleRow() - StateLayout::kPoseDim) =
        speedScaleJacobian(state, twist);
  }
  if (layout.rotation_dim > 0) {
    const int col = layout.rotationRow() - StateLayout::kPoseDim;
    const Eigen::Vector3d v_imu = state.imu_R_twist * scaledVelocity(state, twist);
    du_daux.block<3, 3>(0, col) = -Gv * se3::hat(v_imu);
    du_daux.block<3, 3>(3, col) = -se3::hat(Eigen::Vector3d(u.tail<3>()));
  }
  return du_daux;
}

void Propagator::predict(double dt, const TwistData& twist, double noise_scale,
                         FilterState* state) const {
  const StateLayout& layout = state->layout();
  constexpr int kPoseDim = StateLayout::kPoseDim;
  const Vector6d u = correctedTwist(*state, twist);
  const Vector6d xi = -dt * u;
  state->imu_T_world = se3::exp(xi) * state->imu_T_world;
  se3::normalizeRotation(&state->imu_T_world);

  // World-frame error: T' = exp(eps^) T_mean exp(dt (u - b)^), so eps' = eps + d with
  // d = -dt Ad(T') J_l(xi) db + Ad(T') dt n (n: twist noise). A change d of the pose error moves
  // the invariant landmark errors too: xi_i' = xi_i + p_i^ d_phi (the landmark is static,
  // exp(phi^) p_mean is not). D maps d into the state: identity on the pose, [0, p_i^] on each
  // landmark (SLAM mode; in mapping mode the landmarks do not depend on the pose).
  const Matrix6d Ad = se3::adjoint(se3::inverse(state->imu_T_world));
  const int aux = layout.auxDim();
  // F = I + E on the auxiliary columns, E = D G (dim x aux), G = dt Ad J_l(xi) du/daux. The
  // covariance part is deferred to the next read (FilterState::deferPrediction): with many twists
  // per frame it is applied once.
  const Eigen::MatrixXd G =
      aux > 0 ? Eigen::MatrixXd(dt * Ad * se3::leftJacobian(xi) * twistJacobian(*state, twist, u))
              : Eigen::MatrixXd::Zero(kPoseDim, 0);
  const Matrix6d Q_world = (noise_scale * dt) * Ad * noiseDensity(*state, twist) * Ad.transpose();
  state->deferPrediction(G, Q_world, randomWalkVariances(dt, layout),
                         options_->mode == EstimatorMode::kSlam);
  if (layout.tilt_dim > 0) propagateRoadTilt(dt * u.head<3>().norm(), state);
}

void Propagator::holdStill(double dt, FilterState* state) const {
  const StateLayout& layout = state->layout();
  state->deferPrediction(Eigen::MatrixXd::Zero(StateLayout::kPoseDim, layout.auxDim()),
                         Matrix6d::Zero(), randomWalkVariances(dt, layout),
                         options_->mode == EstimatorMode::kSlam);
}

void Propagator::propagateRoadTilt(double distance, FilterState* state) const {
  // First-order Gauss-Markov over the distance travelled: s' = f s + w, f = exp(-d / L),
  // Var(w) = (1 - f^2) sigma^2, so the road's tilt keeps the stationary std sigma and forgets
  // itself over L. Standing still, nothing changes.
  const double f = std::exp(-distance / options_->vehicle.tilt_correlation_distance);
  const double sigma = options_->vehicle.tilt_sigma;
  state->road_tilt_world *= f;
  state->propagateRoadTiltCovariance(f, (1.0 - f * f) * sigma * sigma);
}

Eigen::VectorXd Propagator::randomWalkVariances(double dt, const StateLayout& layout) const {
  Eigen::VectorXd variances = Eigen::VectorXd::Zero(layout.auxDim());
  auto set = [&](int row, int count, double random_walk) {
    for (int i = 0; i < count; ++i) {
      variances(row - StateLayout::kPoseDim + i) = dt * random_walk * random_walk;
    }
  };
  for (int i = 0; i < layout.biasDim(); ++i) {
    set(layout.biasRow() + i, 1,
        layout.bias_components[i] < 3 ? options_->bias.velocity_random_walk
                                      : options_->bias.gyro_random_walk);
  }
  // A counted (not estimated) scale is a constant: a random walk would reach the gains too.
  if (estimatesSpeedScale(*options_)) {
    set(layout.speedScaleRow(), layout.speed_scale_dim, options_->bias.speed_scale_random_walk);
  }
  set(layout.rotationRow(), layout.rotation_dim, options_->extrinsic.twist_rotation_random_walk);
  if (options_->intrinsic.estimate_disparity_offset) {
    set(layout.disparityRow(), layout.disparity_dim,
        options_->intrinsic.disparity_offset_random_walk);
  }
  set(layout.scaleRow(), layout.scale_dim, options_->intrinsic.baseline_scale_random_walk);
  set(layout.driftRow(), layout.drift_dim, options_->track_drift.rate_random_walk);
  if (layout.gravity_dim > 0) {
    set(layout.accelBiasRow(), 3, options_->gravity.accel_bias_random_walk);
  }
  return variances;
}

}  // namespace ekf_vislam
