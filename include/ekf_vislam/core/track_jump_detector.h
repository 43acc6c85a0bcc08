#pragma once

#include <Eigen/Core>

#include <vector>

namespace ekf_vislam {

/// One re-observed landmark as seen by the jump test: how its left-image residual [uL, v] changed
/// since the previous frame, and how that change depends on a common pose error.
struct FlowCheck {
  /// Residual (measured - predicted, px) of this frame's prediction minus the residual left after
  /// the previous frame's update: the flow the tracker measured minus the flow the filter predicts.
  Eigen::Vector2d residual_change = Eigen::Vector2d::Zero();
  /// d residual_change / d pose error (2 x 6), landmark held fixed.
  Eigen::Matrix<double, 2, 6> H_pose = Eigen::Matrix<double, 2, 6>::Zero();
  /// Variance (px^2) of each component due to the landmark's own uncertainty.
  Eigen::Vector2d landmark_variance = Eigen::Vector2d::Zero();
};

struct TrackJumpOptions {
  double threshold_px = 3.0;  ///< a component beyond this (and beyond the next) is a jump; 0 = off
  double threshold_sigmas = 4.0;  ///< ... and beyond this many robust standard deviations
  int min_checks = 8;             ///< fewer re-observed landmarks: no test (nothing flagged)
  /// More flagged than this fraction: the frame itself is bad (garbage, or a prediction too far
  /// off for the linear fit), not a few slid tracks. Nothing is flagged; the gate decides.
  double max_jump_fraction = 0.3;
};

struct TrackJumpResult {
  std::vector<bool> jumped;  ///< per check
  bool tested = false;       ///< false: too few checks (or off); nothing flagged
  Eigen::Matrix<double, 6, 1> common_pose_error = Eigen::Matrix<double, 6, 1>::Zero();
  double sigma_px = 0.0;  ///< robust standard deviation of the flow errors (MAD)
};

/// Feature-track jump test. Real trackers sometimes slide onto another image point: the track
/// goes on consistently but now belongs to a different 3D point. Frame-to-frame flow is accurate
/// (KITTI tracks: 0.36 px MAD against ground-truth motion), so a jump shows as a flow error far
/// beyond the others once the error common to all landmarks (the pose prediction error) is
/// removed. The common pose error is fitted robustly (Huber IRLS) to all checks; a check whose
/// remaining error exceeds both thresholds in either component is flagged.
TrackJumpResult detectTrackJumps(const std::vector<FlowCheck>& checks,
                                 const TrackJumpOptions& options);

}  // namespace ekf_vislam
