// The stereo tracker over a recorded bag, as stereo_tracker_node tracks the same messages live
// (StereoTrackerRos): the node's own synchronizer (stereo_image_sync.h), fed in bag order, pairs
// within ros/max_stamp_difference taken, the wait for the twist
// that reaches a pair's stamp, the motion prior through /tf_static, restarts when time goes
// back, a new tracker (ids going on) for a new calibration. Fed message by message in bag order
// (track_stereo_bag), it writes every message but the images, plus the features.
#pragma once

#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/ros/bag_reader.h"
#include "ekf_vislam/ros/gray_image.h"
#include "ekf_vislam/ros/stereo_image_sync.h"
#include "ekf_vislam/ros/stereo_pair_rectifier.h"
#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/tracker_options.h"
#include "ekf_vislam/tracker/twist_motion_prior.h"

#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace ekf_vislam {

/// The bag's topics (those of stereo_vislam.launch by default): the image pair's, and the
/// estimator's inputs as the offline runner names them (BagTopics: camera_info, twist, features,
/// /tf_static; its imu_data and wheel_odometry are not read here).
struct BagTrackerTopics : BagTopics {
  std::string left = "/stereo/left/image_rect", right = "/stereo/right/image_rect";
};

/// What a pass over a bag counted.
struct BagTrackingCounts {
  uint64_t left = 0, right = 0, tracked = 0, refused = 0, observations = 0;
  uint64_t pairs = 0;           ///< pairs the synchronizer emitted
  uint64_t unpaired = 0;        ///< images in no pair it emitted (set by finish)
  uint64_t unsynchronized = 0;  ///< pairs further apart than ros/max_stamp_difference, skipped
  uint64_t no_camera_info = 0;  ///< pairs dropped for want of camera_info
  uint64_t twist_predicted = 0;
  uint64_t time_jump_resets = 0;
  uint64_t without_features = 0;   ///< tracked pairs that gave no feature
  uint64_t undecodable = 0;        ///< compressed images that could not be decoded
  std::vector<double> rectify_ms;  ///< wall ms of each pair's rectification (ros/rectify)
};

/// The stereo_tracker_node's tracking thread, fed from a bag in bag order.
class BagStereoTracker {
 public:
  /// `bag_has_twist`: the bag holds topics.twist (pairs wait for it, as the node waits for a
  /// stream that has a publisher). Features go to `out` on topics.features; with a `debug_dir`,
  /// each pair's debug drawing goes there as NNNNNN.png. Everything given must outlive this.
  BagStereoTracker(const BagTrackerTopics& topics, const TrackerOptions& options,
                   const StereoTrackerRosOptions& ros_options, const StereoMasks& masks,
                   bool bag_has_twist, const std::string& debug_dir, rosbag::Bag* out);

  /// One message of the bag, in bag order: an image (Image or CompressedImage) is paired and
  /// tracked when ready; any other message is copied to `out`, and read when it is a camera_info,
  /// a twist or /tf_static.
  void add(const rosbag::MessageInstance& m);
  /// The bag has ended: the pairs still waiting for the twist are tracked (live, their wait
  /// would run out).
  void finish();
  const BagTrackingCounts& counts() const { return counts_; }

 private:
  struct Pair {
    sensor_msgs::ImageConstPtr left, right;
  };
  template <class Image>
  void addToSync(StereoImageSync<Image>* sync, const boost::shared_ptr<const Image>& image,
                 bool is_left);
  /// The synchronizer's pairs: counted, decoded when compressed, then queuePair.
  void addPair(const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right);
  void addCompressedPair(const sensor_msgs::CompressedImageConstPtr& left,
                         const sensor_msgs::CompressedImageConstPtr& right);
  /// As the node's receivePair: a restart when time went back, a pair whose stamps lie further
  /// apart than ros/max_stamp_difference skipped (unsynchronized), the rest waits to be tracked.
  void queuePair(const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right);
  void addTwist(const ros::Time& stamp, const geometry_msgs::Twist& twist,
                const std::string& frame);
  void trackReadyPairs(bool all);
  void track(const Pair& pair);
  /// As the node's: ros/rectify's rectification, and the rectified frame's static tf written.
  bool rectifyPair(cv::Mat* left, cv::Mat* right, std_msgs::Header* header);
  std::optional<CameraMotionPrior> motionPrior(const std::string& camera_frame, double to);
  /// Counts one more in *counter and says `what` on stderr for the first kRefusalsSaid of it.
  void say(uint64_t* counter, const std::string& what);
  void refuse(const std::string& why, double stamp);
  /// As the node: a stamp on `stream` (0 images, 1 twist) that went back in time (a bag played
  /// again) drops every track, waiting pair and twist, and tracking starts again, ids going on.
  void restartIfTimeJumped(int stream, const ros::Time& stamp);

  const BagTrackerTopics& topics_;
  const TrackerOptions& options_;
  const StereoTrackerRosOptions& ros_options_;
  const StereoMasks& masks_;
  const std::string debug_dir_;
  const bool wait_for_twist_;
  rosbag::Bag* out_;
  TimeJumpDetector time_jumps_;
  ros::Time now_;  ///< bag time of the message being handled: where features are written
  std::unique_ptr<StereoImageSync<sensor_msgs::Image>> sync_;
  std::unique_ptr<StereoImageSync<sensor_msgs::CompressedImage>> compressed_sync_;
  std::deque<Pair> waiting_;
  std::deque<StampedTwist> twists_;
  std::string twist_frame_;
  std::vector<geometry_msgs::TransformStamped> static_transforms_;
  sensor_msgs::CameraInfoConstPtr left_info_, right_info_;
  std::unique_ptr<StereoTracker> tracker_;
  StereoPairRectifier rectifier_;  ///< ros/rectify
  DeepImageScale image_scale_;     ///< 16-bit images to 8 (ros/image_bits)
  StereoCalibration stereo_;
  double prev_stamp_ = -1.0;
  bool rig_warned_ = false;
  BagTrackingCounts counts_;
};

}  // namespace ekf_vislam
