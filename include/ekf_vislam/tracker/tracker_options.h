// Every tunable of the stereo tracker in one struct. One key table drives parsing from a
// ParameterSource (a YAML file offline, the ROS parameter server in the nodelet), range checks and
// the start-up description. Keys and documentation: config/tracker.yaml. No ROS.
#pragma once

#include "ekf_vislam/core/option_table.h"
#include "ekf_vislam/core/parameter_source.h"
#include "ekf_vislam/core/twist_message_type.h"

#include <string>
#include <vector>

namespace ekf_vislam {

enum class FeatureDetectorType {
  kFast,       ///< FAST corners, strongest per cell
  kShiTomasi,  ///< minimum eigenvalue corners (goodFeaturesToTrack), strongest per cell
};

enum class TemporalOutlierCheck {
  kNone,         ///< keep every KLT match that passes the forward-backward check
  kFundamental,  ///< RANSAC fundamental matrix over the frame-to-frame matches
  kPnp,          ///< RANSAC PnP of the previous frame's stereo points against the current left
                 ///< image; tracks without a previous stereo depth checked by the epipolar
                 ///< distance of the PnP motion (falls back to kFundamental with too few points)
};

/// How the nodelet receives its images (ros/image_transport).
enum class ImageTransportType {
  kRaw,         ///< sensor_msgs/Image on stereo/{left,right}/image_rect
  kCompressed,  ///< sensor_msgs/CompressedImage on stereo/{left,right}/image_rect/compressed
};

inline constexpr EnumNames<ImageTransportType, 2> kImageTransportNames{
    {{"raw", ImageTransportType::kRaw}, {"compressed", ImageTransportType::kCompressed}}};

struct TrackerOptions {
  // input/
  double max_rate_hz = 0;  ///< pairs closer than kRateSlack / this to the last tracked one are
                           ///< skipped (frame_rate_limit.h); 0 = every pair

  // detector/
  FeatureDetectorType detector = FeatureDetectorType::kFast;
  int grid_cols = 20;  ///< detection grid over the left image
  int grid_rows = 8;
  int max_features_per_cell = 4;      ///< new features only in cells below this count
  double min_feature_distance = 10;   ///< px between two features (new ones keep this from all;
                                      ///< a track half this near an older one ends)
  int fast_threshold = 12;            ///< FAST intensity threshold
  double shi_tomasi_quality = 0.005;  ///< goodFeaturesToTrack qualityLevel (relative)
  int border_px = 8;                  ///< no feature closer than this to the image border
  int confirm_frames = 1;  ///< a new feature is published (and gets its id) once tracked this
                           ///< many frames (0: from its first frame)

  // klt/
  int window_size = 15;              ///< KLT window (px, odd)
  int pyramid_levels = 3;            ///< pyramid levels above the full image (temporal;
                                     ///< one more for a pair without a motion prediction)
  int max_iterations = 10;           ///< KLT iterations per level
  double epsilon = 0.03;             ///< KLT convergence threshold (px)
  double forward_backward_px = 0.5;  ///< max distance of the backward-tracked point to the start
  int back_check_levels = 0;  ///< pyramid levels above the full image of the backward KLT of both
                              ///< back-checks (temporal and left-right; at most the forward's)
  bool predict_with_last_motion = true;  ///< KLT initial guess from the last frame's estimated
                                         ///< motion (for points with a stereo depth); without
                                         ///< one, from a motion fitted first on 100 tracks
  bool exposure_compensation = true;     ///< both KLT steps compare images brought to the same gain
                                         ///< and offset (fitted on the tracks)

  // refine/
  bool refine = true;                ///< align each track's first left patch (affine warp, gain and
                                     ///< bias) to every new left image after the KLT
  int refine_patch_size = 15;        ///< px, odd: side of the reference patch
  int refine_max_iterations = 10;    ///< inverse-compositional iterations
  double refine_epsilon = 0.03;      ///< px, stop when an iteration moves the point by less
  double refine_max_shift_px = 1.0;  ///< a refined position further from the KLT one is refused
  double refine_min_zncc = 0.8;      ///< a refined patch correlating less is refused
  double refine_max_scale_change = 2.0;  ///< the reference is taken anew when the warp scales it
                                         ///< by more than this (or less than its inverse)
  bool refine_end_failed = false;  ///< end a track whose alignment is refused (false: keep the
                                   ///< KLT position and take the reference anew there)
  bool refine_stereo = true;       ///< also align the current left patch to the right image
                                   ///< (affine in u, rows kept) after the left-right KLT

  // stereo/
  int stereo_window_size = 15;        ///< KLT window of the left-right match
  int stereo_pyramid_levels = 4;      ///< pyramid levels of the left-right match
  double row_tolerance_px = 1.0;      ///< max |v_right - v_left| (rectified images)
  double min_disparity_px = 0.5;      ///< smaller disparity: no stereo match
  double max_disparity_px = 200.0;    ///< larger disparity: no stereo match
  double stereo_back_check_px = 0.5;  ///< max distance of the right-to-left match to the start
  double disparity_check_px = 2.0;    ///< a track's disparity may differ from the one its previous
                                      ///< depth and the estimated motion predict by this much plus
  double disparity_check_relative = 0.05;  ///< this fraction of the prediction (0 and 0 = off)
  bool correct_disparity_offset = true;    ///< publish the disparities less the rig's offset once
                                           ///< the rig check reads one beyond its warning level

  // ransac/
  TemporalOutlierCheck outlier_check = TemporalOutlierCheck::kPnp;
  double ransac_threshold_px = 1.0;  ///< inlier threshold (reprojection / epipolar distance)
  double ransac_confidence = 0.99;
  int ransac_iterations = 200;
  int min_ransac_points = 12;     ///< fewer matches: no outlier check this frame
  double max_pnp_depth_m = 60.0;  ///< farther previous stereo points are not used by PnP

  // mask/ (image_mask.h)
  std::string mask_left;   ///< image file: zero pixels of the left image hold no feature ("": none)
  std::string mask_right;  ///< the same for the right image's stereo matches

  /// Empty when every value is usable, else what is wrong (the first problem, naming its key).
  std::string validate() const;
};

/// Fills *options from the keys present in `source` (absent keys keep their value). Returns false
/// and sets *error on a key of the wrong type or an unknown choice, leaving *options unchanged;
/// does not call validate().
bool parseTrackerOptions(const ParameterSource& source, TrackerOptions* options,
                         std::string* error);

/// Every option by group ("detector: type=fast grid_cols=20 ..."; logged by the nodelet at start).
std::string describeOptions(const TrackerOptions& options);

/// Every key of the table ("detector/type", ...), with its kind and range.
std::vector<OptionKeyList::Key> trackerOptionKeys();

/// The nodelet's own options (config/tracker.yaml's ros/ group; StereoTrackerRos). Plain data:
/// the offline tool reads the same file and must know these keys too.
struct StereoTrackerRosOptions {
  int queue_size = 200;                 ///< image, synchronizer and waiting-pair queues
  double max_stamp_difference = 0.002;  ///< s, left and right stamps further apart: unsynchronized
  /// raw: sensor_msgs/Image; compressed: the CompressedImage (png, jpeg) of the same topic's
  /// /compressed, as image_transport names it, decoded on the tracking thread.
  ImageTransportType image_transport = ImageTransportType::kRaw;
  /// The images are raw (stereo/{left,right}/image_raw): rectified with each camera_info's K, D,
  /// R and P before tracking (StereoPairRectifier), the features in "<frame>_rect".
  bool rectify = false;
  /// Significant bits of 16-bit images' values (DeepImageScale): 8-16, or 0 to read them from the
  /// images.
  int image_bits = 0;
  bool use_twist = true;  ///< predict KLT start points from imu/twist (needs tf)
  /// Message type on imu/twist, as the estimator's ros/twist_type: twist_stamped |
  /// twist_with_covariance | odometry (its twist, in child_frame_id).
  TwistMessageType twist_type = TwistMessageType::kTwistStamped;
  double max_twist_wait = 0.5;     ///< s a pair waits for the twist stream (message and wall time)
  double diagnostic_period = 1.0;  ///< s
  double time_jump_reset = 1.0;    ///< s back on one input: the tracker restarts (0 = off)
  double max_backlog_mb = 1000.0;  ///< MB of images received and not yet handled, at most
};

/// Fills *options from the ros/ keys present in `source` and checks their ranges; false and
/// *error set (leaving *options unchanged) on a wrong type or a value out of range.
bool parseTrackerRosOptions(const ParameterSource& source, StereoTrackerRosOptions* options,
                            std::string* error);

/// Every key of the ros/ table ("ros/queue_size", ...).
std::vector<OptionKeyList::Key> trackerRosOptionKeys();

/// The keys of a tracker configuration (the table and the ros/ group) that `source` holds but
/// nothing reads, as one line to warn with ("" when none; parameter_source.h).
std::string unknownTrackerKeys(const ParameterSource& source);

}  // namespace ekf_vislam
