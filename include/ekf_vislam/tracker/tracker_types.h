// Plain data of the stereo tracker: tracked features and per-frame counters out. Its calibration
// is the estimator's StereoCalibration (core/types.h; the tracker reads the intrinsics and
// baseline of the rectified pair, not cam_T_imu). No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <limits>
#include <vector>

namespace ekf_vislam {

/// Optional motion of the left camera between the previous and the current frame, e.g. from
/// the gyro: p_cur = cur_R_prev * p_prev + cur_t_prev (points in the left camera frames).
struct CameraMotionPrior {
  Eigen::Matrix3d cur_R_prev = Eigen::Matrix3d::Identity();
  bool has_translation = false;
  Eigen::Vector3d cur_t_prev = Eigen::Vector3d::Zero();  ///< m, used when has_translation
};

/// One feature of a frame, matched in both images.
struct TrackedFeature {
  uint32_t id = 0;                 ///< persistent track id, never reused
  cv::Point2f left;                ///< rectified left image, px (u right, v down)
  cv::Point2f right;               ///< rectified right image, px
  int age = 0;                     ///< frames since the track was first published (0 in that frame)
  std::vector<cv::Point2f> trail;  ///< its last left positions, oldest first (for drawing)
};

/// Why features left or did not join, and where the time went, in one frame.
struct TrackerFrameStats {
  int tracks_in = 0;  ///< tracks of the previous frame
  int klt_lost = 0;   ///< KLT failed, or left the image or its mask
  int forward_backward_rejected = 0;
  int ransac_rejected = 0;     ///< temporal outliers
  int crowded = 0;             ///< within half of detector/min_feature_distance of an older track
  int stereo_lost = 0;         ///< tracked, but no left-right match in this frame (none
                               ///< found, or on the right mask)
  int disparity_rejected = 0;  ///< left-right match disagrees with the predicted disparity
  // The left-right KLT of the tracks and the new corners (stereo_matcher.h), for the rig check.
  int stereo_converged = 0;           ///< matches the KLT ended inside the right image
  int stereo_row_failed = 0;          ///< of them, rows further apart than stereo/row_tolerance_px
  int stereo_negative_disparity = 0;  ///< of them, the right point right of the left one
  float stereo_row_offset_px = std::numeric_limits<float>::quiet_NaN();  ///< median v_R - v_L
  /// The right image's roll against the left one (stereo_roll_fit.h), degrees, its standard error,
  /// and the rows' difference it makes at the side edge farther from the principal point (px);
  /// NaN without a fit.
  float stereo_roll_deg = std::numeric_limits<float>::quiet_NaN();
  float stereo_roll_sigma_deg = std::numeric_limits<float>::quiet_NaN();
  float stereo_roll_edge_px = std::numeric_limits<float>::quiet_NaN();
  /// The disparity offset (measured minus true, px) and its standard error fitted with this
  /// pair's motion (disparity_offset_fit.h), for the rig check; NaN without a fit.
  float disparity_offset_px = std::numeric_limits<float>::quiet_NaN();
  float disparity_offset_sigma_px = std::numeric_limits<float>::quiet_NaN();
  /// What the published right columns were moved by (px; the rig check's offset once it reads one
  /// beyond its warning level, stereo/correct_disparity_offset), 0 when not.
  float disparity_offset_corrected_px = 0;
  /// Tracks that went on under a new id because the correction started in this pair.
  int ids_renewed = 0;
  int detected = 0;               ///< new corners found
  int new_tracks = 0;             ///< of them, matched in the right image (new ids)
  int published = 0;              ///< features of the frame
  int refined = 0;                ///< tracks aligned to their reference patch (refine/enabled)
  int refine_failed = 0;          ///< alignments refused (the KLT position stands)
  bool motion_estimated = false;  ///< PnP gave the camera motion of this frame
  /// Without a prior or a last motion, the KLT start points came from a motion fitted first on a
  /// subset of the tracks (StereoTracker::predictFromFirstMatches).
  bool predicted_from_first_matches = false;
  double exposure_gain_temporal = 1;  ///< klt/exposure_compensation: previous to this left image
  double exposure_gain_stereo = 1;    ///< and right image to left
  /// Wall times of the stages on the tracking thread. The new left image's pyramid and FAST
  /// corners are made on two more threads meanwhile: ms_pyramids and ms_detect hold only the
  /// wait for them (with the other pyramids, and the corners' selection).
  double ms_pyramids = 0, ms_temporal = 0, ms_ransac = 0, ms_stereo = 0, ms_detect = 0,
         ms_refine = 0;
  double ms_total = 0;
};

/// Result of one stereo pair.
struct StereoFrame {
  double stamp = 0;
  std::vector<TrackedFeature> features;
  TrackerFrameStats stats;
};

}  // namespace ekf_vislam
