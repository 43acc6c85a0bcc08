#include "ekf_vislam/core/repeated_frame_handler.h"

#include "ekf_vislam/core/se3.h"

#include <utility>

namespace ekf_vislam {

void RepeatedFrameHandler::hold(const FeatureFrame& frame, const std::vector<size_t>& new_tracks,
                                const InputScreening& screening, const StereoCamera& camera,
                                FilterState* state, LandmarkManager* landmarks,
                                EstimatorStats* stats, FeedResult* result) {
  // With equal motion over the repeated frame and the next one, the next observation of a track
  // through it is the landmark seen from the pose at the repeated frame (the clone), which
  // bridges the frame. The tracks that start in the repeated frame are fresh measurements at
  // its stamp.
  if (pending()) shiftCrossingTracks(camera, state, landmarks, stats, result);  // twice in a row
  for (const StereoObservation& f : frame.features) {
    const std::optional<size_t> k = landmarks->find(f.id);
    if (!k) continue;
    crossing_ids_.insert(f.id);
    landmarks->track(*k).has_flow_reference = false;  // its next observation is not comparable
  }
  state->clonePose();
  for (size_t i : new_tracks) {
    const StereoObservation& f = frame.features[i];
    if (landmarks->find(f.id) || !screening.screen(f, camera, stats, result)) continue;
    landmarks->initialize(f, frame.stamp, LandmarkManager::kNewMapEntry, camera, state, stats,
                          result);
  }
}

void RepeatedFrameHandler::shiftCovariance(
    const FilterState& state, const Eigen::Matrix3d& R, const Eigen::Vector3d& p_camera_world,
    const std::vector<std::pair<int, Eigen::Matrix3d>>& moved, bool add_depth_noise,
    Eigen::Block<Eigen::MatrixXd> S) const {
  const StateLayout& layout = state.layout();
  const bool slam = layout.clone_dim > 0;
  const int c = layout.cloneRow();
  for (const auto& [row, Rp] : moved) {
    Eigen::MatrixXd rows = R * S.middleRows(row, 3);
    if (slam) {
      rows += S.topRows(3) - Rp * S.middleRows(3, 3) - R * S.middleRows(c, 3) +
              Rp * S.middleRows(c + 3, 3);
    }
    S.middleRows(row, 3) = rows;
  }
  for (const auto& [row, Rp] : moved) {
    Eigen::MatrixXd cols = S.middleCols(row, 3) * R.transpose();
    if (slam) {
      cols += S.leftCols(3) - S.middleCols(3, 3) * Rp.transpose() -
              S.middleCols(c, 3) * R.transpose() + S.middleCols(c + 3, 3) * Rp.transpose();
    }
    S.middleCols(row, 3) = cols;
  }
  const double relative_var =
      options_->limits.repeated_frame_depth_sigma * options_->limits.repeated_frame_depth_sigma;
  for (const auto& moved_row : moved) {
    const int row = moved_row.first;
    S.middleRows(row, 3) = S.middleCols(row, 3).transpose();
    if (!add_depth_noise) continue;
    const Eigen::Vector3d ray = state.landmark((row - layout.headDim()) / 3) - p_camera_world;
    S.block<3, 3>(row, row) += relative_var * ray * ray.transpose();
  }
}

void RepeatedFrameHandler::shiftCrossingTracks(const StereoCamera& camera, FilterState* state,
                                               LandmarkManager* landmarks, EstimatorStats* stats,
                                               FeedResult* result) {
  // p' = Delta p with Delta = world_T_imu * imu_T_world(clone). With the invariant errors
  // (p = exp(phi^) p_mean + xi for the current pose, clone error [rho_c; phi_c]) the new error is
  // xi' = R_D xi + rho - R_D p^ phi - R_D rho_c + R_D p^ phi_c (first order; R_D of Delta), and
  // in mapping mode (no pose errors) xi' = R_D xi. Sigma <- J Sigma J^T, J the identity except
  // the moved landmarks' rows: rows first (each new row uses its own old row and the pose and
  // clone rows, which do not change), then columns the same way.
  const Eigen::Matrix4d world_T_imu = se3::inverse(state->imu_T_world);
  const Eigen::Matrix4d delta = world_T_imu * state->imu_T_world_clone;
  const Eigen::Matrix3d R = delta.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = delta.topRightCorner<3, 1>();
  const StateLayout& layout = state->layout();
  std::vector<std::pair<int, Eigen::Matrix3d>> moved;  // landmark row, R_D p^ (old mean)
  for (uint32_t id : crossing_ids_) {
    const std::optional<size_t> k = landmarks->find(id);
    if (!k) continue;  // ended, or restarted from its new observation
    const Eigen::Vector3d p = state->landmark(*k);
    moved.emplace_back(layout.landmarkRow(*k), R * se3::hat(p));
    state->setLandmark(*k, R * p + t);
    landmarks->track(*k).has_flow_reference = false;
    stats->increment(Counter::kLandmarkShifted);
    ++result->landmarks_shifted;
  }
  const Eigen::Vector3d p_camera_world =
      world_T_imu.topLeftCorner<3, 3>() * camera.imuTCam().topRightCorner<3, 1>() +
      world_T_imu.topRightCorner<3, 1>();
  for (int which = 0; which < state->carriedCount(); ++which) {
    // The shift's depth noise is not the tracks' update noise: not in the track-noise parts.
    shiftCovariance(*state, R, p_camera_world, moved, which < state->covarianceCount(),
                    state->covariance(which));
  }
  crossing_ids_.clear();
}

}  // namespace ekf_vislam
