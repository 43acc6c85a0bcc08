#include "ekf_vislam/core/gravity_updater.h"

#include "ekf_vislam/core/chi_square.h"
#include "ekf_vislam/core/se3.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

namespace ekf_vislam {

namespace {

/// A window whose samples cover less of it than this is not used.
constexpr double kMinCoverage = 0.9;
/// Chi-square gate of a window (3 dof).
constexpr double kGateProbability = 0.9999;

}  // namespace

Eigen::Vector3d upFromLevel(const Eigen::Vector2d& level_world) {
  const double z2 = 1.0 - level_world.squaredNorm();
  return Eigen::Vector3d(level_world.x(), level_world.y(), std::sqrt(std::max(z2, 1e-6)));
}

GravityObservation predictGravity(const Eigen::Matrix3d& world_R_imu,
                                  const Eigen::Vector2d& level_world,
                                  const Eigen::Vector3d& accel_bias_imu, double magnitude) {
  const Eigen::Vector3d up = upFromLevel(level_world);
  GravityObservation obs;
  obs.predicted = magnitude * world_R_imu.transpose() * up + accel_bias_imu;
  // R = exp(phi^) R_mean: R^T up = R_mean^T (up + up^ phi) to first order.
  obs.H_phi = magnitude * world_R_imu.transpose() * se3::hat(up);
  Eigen::Matrix<double, 3, 2> dup_dlevel;
  dup_dlevel << 1.0, 0.0, 0.0, 1.0, -up.x() / up.z(), -up.y() / up.z();
  obs.H_level = magnitude * world_R_imu.transpose() * dup_dlevel;
  return obs;
}

GravityUpdater::GravityUpdater(const VislamOptions& options)
    : options_(&options),
      noise_estimator_(options.noise.twist_noise_window, options.noise.twist_noise_min_samples) {}

void GravityUpdater::reset() {
  noise_estimator_ = TwistNoiseEstimator(options_->noise.twist_noise_window,
                                         options_->noise.twist_noise_min_samples);
  pending_.clear();
  last_added_stamp_ = kNoStamp;
  last_twist_stamp_ = kNoStamp;
  p_accel_in_imu_.setZero();
  windows_open_after_ = kNoStamp;
  open_ = false;
}

bool GravityUpdater::addSample(const AccelerometerData& sample, EstimatorStats* stats) {
  if (sample.stamp <= last_twist_stamp_ || sample.stamp <= last_added_stamp_) {
    stats->increment(Counter::kAccelLate);
    return false;
  }
  TwistData as_twist;  // the estimator's white-noise estimate, the sample as a linear part
  as_twist.stamp = sample.stamp;
  as_twist.v_imu = sample.f_imu;
  noise_estimator_.add(as_twist);
  const bool first = last_added_stamp_ == kNoStamp;
  // The first window starts a window length after the first sample: live, the first samples
  // may reach the estimator after a few twists (a connection made later than the others'), and
  // this margin keeps the windows those of the same input offline.
  if (first) windows_open_after_ = sample.stamp + options_->gravity.window;
  PendingSample pending{sample, last_added_stamp_, 0.0};
  pending.variance = sample.hasCovariance()
                         ? sample.covariance.trace() / 3.0
                         : std::pow(sampleSigma(first ? options_->gravity.window
                                                      : sample.stamp - last_added_stamp_),
                                    2);
  last_added_stamp_ = sample.stamp;
  pending_.push_back(pending);
  stats->increment(Counter::kAccelUsed);
  while (pending_.size() > kMaxPending) pending_.pop_front();
  return true;
}

double GravityUpdater::sampleSigma(double period) const {
  if (options_->noise.estimate_twist_noise && noise_estimator_.linearReady()) {
    return noise_estimator_.linearSigma();
  }
  return options_->gravity.accel_noise_density / std::sqrt(std::max(period, 1e-4));
}

void GravityUpdater::integrateSamples(double twist_stamp, const Eigen::Vector3d& w) {
  while (!pending_.empty() && pending_.front().sample.stamp <= twist_stamp) {
    const AccelerometerData sample = pending_.front().sample;
    const double previous = pending_.front().previous_stamp;
    const double variance = pending_.front().variance;
    pending_.pop_front();
    p_accel_in_imu_ = sample.p_accel_in_imu;
    if (!open_ || previous == kNoStamp || sample.stamp <= start_) continue;
    const double dt = sample.stamp - std::max(previous, start_);
    const Eigen::Matrix3d start_R_sample =
        start_R_now_ * se3::expSO3(w * (sample.stamp - last_twist_stamp_));
    const Eigen::Vector3d a = start_R_sample * sample.f_imu * dt;
    force_sum_ += a;
    force_time_sum_ += a * (sample.stamp - start_);
    covered_ += dt;
    rotation_sum_ += start_R_sample * dt;
    force_variance_ += dt * dt * variance;
  }
}

std::pair<Eigen::Vector3d, Eigen::Matrix3d> GravityUpdater::accelVelocity(
    const Vector6d& u, const Matrix6d& u_covariance) const {
  // v + w^ r = [I, -r^] u.
  Eigen::Matrix<double, 3, 6> J;
  J << Eigen::Matrix3d::Identity(), -se3::hat(p_accel_in_imu_);
  return {J * u, J * u_covariance * J.transpose()};
}

void GravityUpdater::openWindow(double stamp, const Vector6d& u, const Matrix6d& u_covariance,
                                const Eigen::Vector3d& d_v_d_scale) {
  open_ = true;
  start_ = stamp;
  std::tie(v_start_, v_start_covariance_) = accelVelocity(u, u_covariance);
  v_start_d_scale_ = d_v_d_scale;
  start_R_now_.setIdentity();
  force_sum_.setZero();
  force_time_sum_.setZero();
  covered_ = 0.0;
  rotation_sum_.setZero();
  force_variance_ = 0.0;
  rotation_covariance_.setZero();
}

std::optional<UpdateStatus> GravityUpdater::onTwist(double twist_stamp, const Vector6d& u,
                                                    const Matrix6d& u_covariance,
                                                    const Eigen::MatrixXd& d_w_d_bias,
                                                    const Eigen::Vector3d& d_v_d_scale,
                                                    FilterState* state, EstimatorStats* stats) {
  // Without an accelerometer (yet) no window opens: nothing to count.
  if (twist_stamp <= last_twist_stamp_ || !hasSamples()) return std::nullopt;
  const Eigen::Vector3d w = u.tail<3>();
  if (open_) {
    integrateSamples(twist_stamp, w);
    const double dt = twist_stamp - last_twist_stamp_;
    start_R_now_ = start_R_now_ * se3::expSO3(w * dt);
    rotation_covariance_ += u_covariance.bottomRightCorner<3, 3>() * dt * dt;
  } else {
    // Samples before a window's first twist belong to no window.
    integrateSamples(twist_stamp, w);
  }
  last_twist_stamp_ = twist_stamp;
  if (!open_) {
    // The state gets its gravity rows with the first window.
    if (twist_stamp > windows_open_after_) {
      windows_open_after_ = kNoStamp;
      state->addGravityRows(options_->gravity.level_sigma, options_->gravity.accel_bias_sigma);
      openWindow(twist_stamp, u, u_covariance, d_v_d_scale);
    }
    return std::nullopt;
  }
  if (twist_stamp - start_ < options_->gravity.window) return std::nullopt;
  // Close; the next twist opens the next window, so no two windows share a velocity sample.
  open_ = false;
  if (covered_ < kMinCoverage * (twist_stamp - start_)) {
    stats->increment(Counter::kGravityIncomplete);
    return std::nullopt;
  }
  const auto [v_end, v_end_covariance] = accelVelocity(u, u_covariance);
  last_window_ = closeWindow(twist_stamp, v_end, v_end_covariance, d_v_d_scale);
  return apply(last_window_, d_w_d_bias, state, stats);
}

GravityWindow GravityUpdater::closeWindow(double end, const Eigen::Vector3d& v_end,
                                          const Eigen::Matrix3d& v_end_covariance,
                                          const Eigen::Vector3d& d_v_d_scale) const {
  GravityWindow window;
  window.end = end;
  window.duration = end - start_;
  const double duration = window.duration;
  const Eigen::Matrix3d end_R_start = start_R_now_.transpose();
  const Eigen::Vector3d mean_force = end_R_start * force_sum_ / covered_;
  const Eigen::Vector3d v_start_end = end_R_start * v_start_;
  window.z = mean_force - (v_end - v_start_end) / duration;
  // A rate error turns every rotation into the end frame: d(R_{b<-x} y) = (s_b - x) (R y)^ dw.
  const Eigen::Vector3d turned = end_R_start * (force_sum_ * duration - force_time_sum_) / covered_;
  // The lever arm's velocities w^ r at both ends move with the rate too: d(w^ r) = -r^ dw.
  const Eigen::Matrix3d r_hat = se3::hat(p_accel_in_imu_);
  window.dz_dw =
      se3::hat(turned) + se3::hat(v_start_end) + (r_hat - end_R_start * r_hat) / duration;
  window.dz_dbias = end_R_start * rotation_sum_ / covered_;
  window.dz_dscale = -(d_v_d_scale - end_R_start * v_start_d_scale_) / duration;
  const Eigen::Vector3d rotated = mean_force + v_start_end / duration;
  window.noise = Eigen::Matrix3d::Identity() * force_variance_ / (covered_ * covered_) +
                 (v_end_covariance + end_R_start * v_start_covariance_ * end_R_start.transpose()) /
                     (duration * duration) +
                 se3::hat(rotated) * rotation_covariance_ * se3::hat(rotated).transpose();
  return window;
}

UpdateStatus GravityUpdater::apply(const GravityWindow& window, const Eigen::MatrixXd& d_w_d_bias,
                                   FilterState* state, EstimatorStats* stats) {
  const StateLayout& layout = state->layout();
  const Eigen::Matrix3d world_R_imu = se3::inverse(state->imu_T_world).topLeftCorner<3, 3>();
  const GravityObservation obs = predictGravity(world_R_imu, state->gravity_level_world,
                                                state->accel_bias_imu, options_->gravity.magnitude);
  // Whitened: the updater takes unit noise.
  const Eigen::LLT<Eigen::Matrix3d> llt(window.noise);
  if (llt.info() != Eigen::Success) return UpdateStatus::kNotPositiveDefinite;
  const auto L = llt.matrixL();
  // predictGravity adds the bias as it is at s_b; over the window it turned with the IMU.
  const Eigen::Vector3d predicted =
      obs.predicted - state->accel_bias_imu + window.dz_dbias * state->accel_bias_imu;
  const Eigen::VectorXd residual = L.solve(window.z - predicted);
  auto whiten = [&](const Eigen::MatrixXd& H) -> Eigen::MatrixXd { return L.solve(H); };
  Eigen::MatrixXd H_pose = Eigen::MatrixXd::Zero(3, StateLayout::kPoseDim);
  H_pose.rightCols<3>() = obs.H_phi;
  SparseJacobian jacobian{{StateLayout::kPoseRow, whiten(H_pose)},
                          {layout.levelRow(), whiten(obs.H_level)},
                          {layout.accelBiasRow(), whiten(window.dz_dbias)}};
  if (d_w_d_bias.cols() > 0) {
    // The rates were corrected with the current bias: z moves by -dz/dw dw/db db.
    jacobian.push_back({layout.biasRow(), whiten(-window.dz_dw * d_w_d_bias)});
  }
  if (layout.speed_scale_dim > 0) {
    jacobian.push_back({layout.speedScaleRow(), whiten(window.dz_dscale)});
  }
  if (state_helper::mahalanobis2(*state, jacobian, residual, 1.0) >
      chiSquareQuantile(kGateProbability, 3)) {
    stats->increment(Counter::kGravityGated);
    return UpdateStatus::kApplied;
  }
  const UpdateOutcome outcome = state_helper::update(state, {jacobian}, residual, 1.0, true, 1.0);
  if (outcome.status == UpdateStatus::kApplied) stats->increment(Counter::kGravityUpdate);
  return outcome.status;
}

}  // namespace ekf_vislam
