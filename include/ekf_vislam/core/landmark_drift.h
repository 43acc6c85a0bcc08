// Track drift as process noise on the landmarks (noise/track_random_walk). A feature tracker's
// error along a track is not white: it wanders like a random walk (the KITTI course tracks: the
// variance of the error difference over L frames grows about linearly in L, 0.5-0.75 px^2 per
// frame at 10 Hz, with almost no white part). A landmark fitted to such a track is the point the
// track shows, and that point moves across the camera ray at the track's pixel rate times
// depth / focal length. Letting each active landmark's error random-walk that way keeps the
// pose from being pulled along by every drifting track as if it were a fixed point. No ROS.
#pragma once

#include <Eigen/Core>

namespace ekf_vislam {

class FilterState;
class StereoCamera;

namespace landmark_drift {

/// World-frame covariance (3 x 3) of a landmark's move across the camera ray when its track's
/// pixel error takes a random step of variance pixel_variance (px^2) in each image axis: the
/// camera-frame diagonal (z/fx)^2, (z/fy)^2, 0 (along the ray) rotated by R_world_cam. The
/// depth z is the point's camera-frame z, at least min_depth.
Eigen::Matrix3d acrossRayCovariance(const Eigen::Matrix3d& R_world_cam,
                                    const Eigen::Vector3d& p_cam, double fx, double fy,
                                    double pixel_variance, double min_depth = 1.0);

/// Adds, to every active landmark's diagonal block of every carried covariance, the drift of
/// random_walk_px (px/sqrt(s)) over dt seconds, seen from the current pose estimate. Nothing
/// for random_walk_px <= 0 or dt <= 0.
void apply(const StereoCamera& camera, double random_walk_px, double dt, FilterState* state);

}  // namespace landmark_drift
}  // namespace ekf_vislam
