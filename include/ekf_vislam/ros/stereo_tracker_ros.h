// The ROS side of the stereo tracker, shared by StereoTrackerNodelet and stereo_tracker_node:
// synchronized rectified images and their camera_info in, ekf_vislam/StereoFeatureArray out
// (plus a debug image when someone listens), bad input warned about (throttled) and counted in
// diagnostics. A thin layer over the ROS-free StereoTracker.
#pragma once

#include "ekf_vislam/core/stamp_gap_detector.h"
#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/tracker/stereo_rig_check.h"
#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/twist_motion_prior.h"

#include "ekf_vislam/ros/gray_image.h"
#include "ekf_vislam/ros/periodic_diagnostics.h"
#include "ekf_vislam/ros/stereo_image_sync.h"
#include "ekf_vislam/ros/stereo_pair_rectifier.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <image_transport/image_transport.h>
#include <message_filters/subscriber.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Geometry>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

namespace ekf_vislam {

/// Callbacks only post what arrives to an inbox; one tracking thread handles it in arrival order
/// (under mutex_), so a pair late for tracking waits there instead of in a ROS queue that would
/// drop it, up to ros/max_backlog_mb of images.
class StereoTrackerRos {
 public:
  /// Reads the tracker options from `pnh` (throws std::runtime_error when invalid).
  StereoTrackerRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name);
  /// Stops the tracking thread (what is still in the inbox is not handled).
  ~StereoTrackerRos();

 private:
  struct ImagePair {
    sensor_msgs::ImageConstPtr left, right;
    double arrival;  ///< when the synchronizer delivered it (its InboxEvent's arrival)
  };

  struct InboxEvent {
    std::function<void()> run;  ///< on the tracking thread, under mutex_
    size_t image_bytes = 0;     ///< of the images it holds (ros/max_backlog_mb)
    double arrival = 0.0;       ///< when it was posted (steadyClockSeconds)
  };

  /// Queues `event` for the tracking thread; false when it is not queued: a pair (image_bytes >
  /// 0) that would take the images waiting beyond ros/max_backlog_mb is dropped (counted,
  /// warned), and nothing is queued once the node stops.
  bool post(std::function<void()> event, size_t image_bytes = 0);
  void trackingThread();
  /// Subscribes to the image pairs of ros/image_transport, synchronized.
  void subscribeImages();
  void imageCallback(const sensor_msgs::ImageConstPtr& left,
                     const sensor_msgs::ImageConstPtr& right);
  /// ros/image_transport compressed: the pair is decoded on the tracking thread, then received as
  /// a raw one; a pair with an image that does not decode is counted (undecodable_images).
  void compressedImageCallback(const sensor_msgs::CompressedImageConstPtr& left,
                               const sensor_msgs::CompressedImageConstPtr& right);
  /// Posts a synchronized pair's `event` (the pair's `image_bytes`, left stamp `stamp`); a pair
  /// dropped from a full backlog still leaves its stamp, so that pairs_missing counts only what
  /// never came.
  void postPair(std::function<void()> event, size_t image_bytes, double stamp);
  /// A synchronized pair on the tracking thread: checked, then waits in waiting_pairs_ until
  /// pairReady.
  void receivePair(const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right);
  /// Tracks the waiting pairs that are ready, oldest first (caller holds mutex_). The waits are
  /// judged at event_arrival_, not at the clock: everything that came before the event being
  /// handled has been handled (the inbox keeps order), so a tracking thread that is late decides
  /// what a prompt one would have, and gives up on no twist that has already come.
  void processReadyPairs();
  /// Both camera_info messages have arrived (nothing can be tracked before).
  bool hasCameraInfo() const { return left_info_ && right_info_; }
  /// A pair is tracked once both camera_infos are known and, with ros/use_twist, once the twist
  /// stream reaches its stamp, or once it has waited ros/max_twist_wait in message time (a pair
  /// that much newer waits behind it) and in wall time (lateStreamWaitIsOver). Before the first
  /// twist a pair waits so only when imu/twist has a publisher.
  bool pairReady(const ImagePair& pair, double now) const;
  void trackPair(const ImagePair& pair);
  void leftInfoCallback(const sensor_msgs::CameraInfoConstPtr& msg);
  void rightInfoCallback(const sensor_msgs::CameraInfoConstPtr& msg);
  void twistCallback(const geometry_msgs::TwistStampedConstPtr& msg);
  void twistWithCovarianceCallback(const geometry_msgs::TwistWithCovarianceStampedConstPtr& msg);
  void odometryTwistCallback(const nav_msgs::OdometryConstPtr& msg);
  /// One twist sample of the motion prior (any of the three message types), posted.
  void addTwist(const ros::Time& stamp, const geometry_msgs::Twist& twist,
                const std::string& frame);
  void receiveTwist(const ros::Time& stamp, const geometry_msgs::Twist& twist,
                    const std::string& frame);
  /// True when `stamp` on `stream` (0 images, 1 twist) went back in time: then every track,
  /// waiting pair and twist is dropped, and tracking starts again with new ids.
  bool restartIfTimeJumped(int stream, const ros::Time& stamp);
  /// False (warned, counted) for a pair that can never be tracked: stamps further apart than
  /// ros/max_stamp_difference, an encoding the tracker does not take (gray_image.h), sizes that
  /// differ.
  /// Checked at arrival, so such a pair does not wait for the twist stream.
  bool wellFormed(const sensor_msgs::Image& left, const sensor_msgs::Image& right);
  /// Counts and warns about pairs missing before this one (StampGapDetector on the left stamps).
  void noteMissingPairs(double stamp);
  bool calibrationFor(const sensor_msgs::Image& left, StereoCalibration* stereo, std::string* why);
  std::optional<CameraMotionPrior> motionPrior(const std::string& camera_frame, double from,
                                               double to);
  /// ros/rectify: both images rectified in place and *header's frame made the rectified one
  /// (its static tf published when new); false (warned, counted) when the camera_info pair
  /// cannot rectify them.
  bool rectifyPair(cv::Mat* left, cv::Mat* right, std_msgs::Header* header);
  void publish(const std_msgs::Header& header, const cv::Mat& left, const cv::Mat& right,
               const StereoFrame& frame);
  /// The diagnostics callback: never waits for the tracking thread (see the .cc).
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// pairs_dropped_backlog_, read under the inbox lock.
  uint64_t droppedFromBacklog();
  /// The status from the members (caller holds mutex_), backlog fields aside; pairs dropped from
  /// the backlog count among the skipped pairs of its summary.
  void fillDiagnostics(uint64_t dropped_from_backlog,
                       diagnostic_updater::DiagnosticStatusWrapper& status) const;
  /// The tracker's rig check, or an empty one before the first pair (caller holds mutex_).
  const StereoRigCheck& rigCheck() const;
  /// On the tracking thread after each event: the status for a callback that found it busy.
  void cacheDiagnosticsIfRequested();
  /// Every 0.1 s of wall time: tracks the pairs whose wait for the twist stream is over.
  void waitTimer(const ros::WallTimerEvent&);

  ros::NodeHandle nh_, pnh_;
  std::string name_;
  TrackerOptions options_;
  StereoMasks masks_;  ///< read once at start (mask/left, mask/right)
  StereoTrackerRosOptions ros_options_;
  std::unique_ptr<StereoTracker> tracker_;
  StereoCalibration stereo_;

  image_transport::ImageTransport image_transport_;
  message_filters::Subscriber<sensor_msgs::Image> left_sub_, right_sub_;
  std::unique_ptr<StereoImageSync<sensor_msgs::Image>> sync_;
  message_filters::Subscriber<sensor_msgs::CompressedImage> left_compressed_sub_,
      right_compressed_sub_;
  std::unique_ptr<StereoImageSync<sensor_msgs::CompressedImage>> compressed_sync_;
  ros::Subscriber left_info_sub_, right_info_sub_, twist_sub_;
  ros::Publisher features_pub_;
  image_transport::Publisher debug_pub_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> rectified_frame_broadcaster_;  ///< rectify
  std::unique_ptr<PeriodicDiagnostics> diagnostics_;
  ros::WallTimer wait_timer_;

  std::mutex inbox_mutex_;  ///< guards the inbox and its counters; never held while tracking
  std::condition_variable inbox_cv_;
  std::deque<InboxEvent> inbox_;
  size_t inbox_image_bytes_ = 0, peak_backlog_bytes_ = 0;
  uint64_t pairs_dropped_backlog_ = 0;
  bool stopping_ = false;
  std::atomic<bool> tick_posted_{false};  ///< a waitTimer check is in the inbox
  std::thread tracking_thread_;
  std::atomic<bool> diagnostics_requested_{false};  ///< a callback found the thread busy
  std::mutex diagnostics_cache_mutex_;
  diagnostic_msgs::DiagnosticStatus diagnostics_cache_;  ///< left by the tracking thread

  std::mutex mutex_;            ///< guards everything below: held by the tracking thread per event
  double event_arrival_ = 0.0;  ///< the arrival of the event being handled (InboxEvent)
  sensor_msgs::CameraInfoConstPtr left_info_, right_info_;
  std::deque<StampedTwist> twists_;      ///< imu/twist samples, stamp order
  std::string twist_frame_;              ///< their frame (the last one received)
  std::deque<ImagePair> waiting_pairs_;  // in stamp order
  double prev_stamp_ = -1;
  // Counters (diagnostics).
  uint64_t pairs_received_ = 0, pairs_tracked_ = 0, bad_encoding_ = 0, size_mismatch_ = 0;
  uint64_t unsynchronized_ = 0, missing_camera_info_ = 0, bad_camera_info_ = 0;
  uint64_t tracker_refused_ = 0, twist_used_ = 0, pairs_dropped_waiting_ = 0;
  uint64_t pairs_out_of_order_ = 0, time_jump_resets_ = 0;
  uint64_t pairs_skipped_rate_ = 0;      ///< not due under input/max_rate_hz
  uint64_t first_fit_predictions_ = 0;   ///< pairs predicted from a motion fitted first
  uint64_t pairs_without_features_ = 0;  ///< tracked pairs that gave no feature (dark, flat images)
  uint64_t undecodable_images_ = 0;      ///< compressed images that did not decode
  double decode_ms_last_ = 0.0;          ///< wall ms the last compressed pair took to decode
  StereoPairRectifier rectifier_;        ///< ros/rectify
  DeepImageScale image_scale_;           ///< 16-bit images to 8 (ros/image_bits)
  uint64_t tracks_crowded_ = 0;          ///< tracks ended near an older one (TrackerFrameStats)
  TimeJumpDetector time_jumps_{0.0, 2};  ///< images 0, twist 1 (set from ros/time_jump_reset)
  StampGapDetector pair_gaps_;           ///< pairs missing, from gaps in the left stamps
  TrackerFrameStats last_stats_;         ///< of the last pair tracked (diagnostics)
};

}  // namespace ekf_vislam
