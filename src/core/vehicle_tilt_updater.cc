#include "ekf_vislam/core/vehicle_tilt_updater.h"

#include "ekf_vislam/core/se3.h"

#include <vector>

namespace ekf_vislam {

TiltObservation observeTilt(const Eigen::Matrix3d& world_R_imu,
                            const Eigen::Vector2d& road_tilt_world) {
  // With R = exp(phi^) R_mean, up = R e3 = up_mean - up_mean^ phi to first order.
  const Eigen::Vector3d up = world_R_imu.col(2);
  TiltObservation obs;
  obs.residual = road_tilt_world - up.head<2>();
  obs.H_phi = -se3::hat(up).topRows<2>();
  return obs;
}

std::optional<UpdateStatus> VehicleTiltUpdater::update(double time, FilterState* state) {
  const StateLayout& layout = state->layout();
  if (layout.tilt_dim == 0) return std::nullopt;
  if (last_update_time_ == kNever) last_update_time_ = time;
  if (time - last_update_time_ < options_->vehicle.tilt_update_period) return std::nullopt;
  last_update_time_ = time;
  const Eigen::Matrix3d world_R_imu = se3::inverse(state->imu_T_world).topLeftCorner<3, 3>();
  const TiltObservation obs = observeTilt(world_R_imu, state->road_tilt_world);
  Eigen::MatrixXd H_pose = Eigen::MatrixXd::Zero(2, StateLayout::kPoseDim);
  H_pose.rightCols<3>() = obs.H_phi;
  const std::vector<SparseJacobian> jacobians{
      {{StateLayout::kPoseRow, H_pose}, {layout.tiltRow(), -Eigen::MatrixXd::Identity(2, 2)}}};
  // The body's tilt is no track error: the reported covariance takes the same noise.
  const double variance = options_->vehicle.body_tilt_sigma * options_->vehicle.body_tilt_sigma;
  return state_helper::update(state, jacobians, obs.residual, variance, true, variance).status;
}

}  // namespace ekf_vislam
