#include "ekf_vislam/ros/bag_stereo_tracker.h"

#include "ekf_vislam/ros/bag_reader.h"
#include "ekf_vislam/ros/feature_message.h"
#include "ekf_vislam/ros/gray_image.h"
#include "ekf_vislam/tracker/debug_drawing.h"
#include "ekf_vislam/tracker/frame_rate_limit.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/message_event.h>
#include <rosbag/bag.h>
#include <rosbag/message_instance.h>
#include <sensor_msgs/CompressedImage.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

namespace ekf_vislam {

namespace {

constexpr uint64_t kRefusalsSaid = 10;  // of each kind, said one by one; the rest counted

// A stamp as the messages give it (s, 6 decimals).
std::string stampText(double stamp) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6f", stamp);
  return text;
}

}  // namespace

BagStereoTracker::BagStereoTracker(const BagTrackerTopics& topics, const TrackerOptions& options,
                                   const StereoTrackerRosOptions& ros_options,
                                   const StereoMasks& masks, bool bag_has_twist,
                                   const std::string& debug_dir, rosbag::Bag* out)
    : topics_(topics),
      options_(options),
      ros_options_(ros_options),
      masks_(masks),
      debug_dir_(debug_dir),
      wait_for_twist_(ros_options.use_twist && bag_has_twist),
      out_(out),
      time_jumps_(ros_options.time_jump_reset, 2),
      sync_(makeStereoImageSync<sensor_msgs::Image>(ros_options)),
      compressed_sync_(makeStereoImageSync<sensor_msgs::CompressedImage>(ros_options)) {
  sync_->registerCallback(&BagStereoTracker::addPair, this);
  compressed_sync_->registerCallback(&BagStereoTracker::addCompressedPair, this);
  image_scale_ = DeepImageScale(ros_options.image_bits);
}

void BagStereoTracker::add(const rosbag::MessageInstance& m) {
  now_ = m.getTime();
  const std::string& topic = m.getTopic();
  if (topic == topics_.left || topic == topics_.right) {
    // Into the node's synchronizer, received at the bag time; it calls addPair or
    // addCompressedPair for each pair it emits.
    const bool is_left = topic == topics_.left;
    ++(is_left ? counts_.left : counts_.right);
    if (const auto image = m.instantiate<sensor_msgs::Image>()) {
      addToSync<sensor_msgs::Image>(sync_.get(), image, is_left);
    } else if (const auto compressed = m.instantiate<sensor_msgs::CompressedImage>()) {
      addToSync<sensor_msgs::CompressedImage>(compressed_sync_.get(), compressed, is_left);
    }
    trackReadyPairs(false);
    return;
  }
  out_->write(topic, m.getTime(), m, m.getConnectionHeader());
  if (topic == topics_.left_info) {
    left_info_ = m.instantiate<sensor_msgs::CameraInfo>();
  } else if (topic == topics_.right_info) {
    right_info_ = m.instantiate<sensor_msgs::CameraInfo>();
  } else if (topic == topics_.tf_static) {
    if (const auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
      static_transforms_.insert(static_transforms_.end(), tf->transforms.begin(),
                                tf->transforms.end());
    }
  } else if (topic == topics_.twist) {
    if (const auto t = m.instantiate<geometry_msgs::TwistStamped>()) {
      addTwist(t->header.stamp, t->twist, t->header.frame_id);
    } else if (const auto c = m.instantiate<geometry_msgs::TwistWithCovarianceStamped>()) {
      addTwist(c->header.stamp, c->twist.twist, c->header.frame_id);
    } else if (const auto o = m.instantiate<nav_msgs::Odometry>()) {
      addTwist(o->header.stamp, o->twist.twist, o->child_frame_id);
    }
  }
  trackReadyPairs(false);
}

template <class Image>
void BagStereoTracker::addToSync(StereoImageSync<Image>* sync,
                                 const boost::shared_ptr<const Image>& image, bool is_left) {
  const ros::MessageEvent<const Image> event(image, now_);
  if (is_left) {
    sync->template add<0>(event);
  } else {
    sync->template add<1>(event);
  }
}

void BagStereoTracker::addPair(const sensor_msgs::ImageConstPtr& left,
                               const sensor_msgs::ImageConstPtr& right) {
  ++counts_.pairs;
  queuePair(left, right);
}

void BagStereoTracker::addCompressedPair(const sensor_msgs::CompressedImageConstPtr& left,
                                         const sensor_msgs::CompressedImageConstPtr& right) {
  // As the node: the pair decoded after the synchronizer, both images counted when they fail.
  ++counts_.pairs;
  const DecompressedPair pair = decompressedPair(*left, *right);
  if (pair.left && pair.right) return queuePair(pair.left, pair.right);
  for (const auto& [image, why] :
       {std::make_pair(pair.left, pair.why_left), std::make_pair(pair.right, pair.why_right)}) {
    if (!image) {
      say(&counts_.undecodable,
          "pair at " + stampText(left->header.stamp.toSec()) + ": " + why + ": skipped");
    }
  }
}

void BagStereoTracker::queuePair(const sensor_msgs::ImageConstPtr& left,
                                 const sensor_msgs::ImageConstPtr& right) {
  restartIfTimeJumped(0, left->header.stamp);
  const double apart = (left->header.stamp - right->header.stamp).toSec();
  if (std::abs(apart) > ros_options_.max_stamp_difference) {
    return say(&counts_.unsynchronized, "pair at " + stampText(left->header.stamp.toSec()) +
                                            ": left and right images " + stampText(apart) +
                                            " s apart (more than ros/max_stamp_difference): "
                                            "skipped");
  }
  waiting_.push_back({left, right});
}

void BagStereoTracker::addTwist(const ros::Time& stamp, const geometry_msgs::Twist& t,
                                const std::string& frame) {
  restartIfTimeJumped(1, stamp);
  const StampedTwist sample{stamp.toSec(), Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z),
                            Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z)};
  if (keepTwist(sample, prev_stamp_, &twists_)) twist_frame_ = frame;
}

void BagStereoTracker::trackReadyPairs(bool all) {
  if (!left_info_ || !right_info_) {
    // As the node: without camera_info the newest ros/queue_size pairs wait, older ones drop.
    while (waiting_.size() > static_cast<size_t>(ros_options_.queue_size)) {
      waiting_.pop_front();
      ++counts_.no_camera_info;
    }
    return;
  }
  while (!waiting_.empty()) {
    const double stamp = waiting_.front().left->header.stamp.toSec();
    // The node's wait, in message time: for the twist that reaches the pair, or until a pair
    // ros/max_twist_wait newer waits behind it (the twist stream stopped).
    const bool ready =
        all || !wait_for_twist_ || (!twists_.empty() && twists_.back().stamp >= stamp) ||
        waiting_.back().left->header.stamp.toSec() - stamp >= ros_options_.max_twist_wait;
    if (!ready) return;
    const Pair pair = waiting_.front();
    waiting_.pop_front();
    track(pair);
  }
}

void BagStereoTracker::finish() {
  // Images the synchronizer dropped or holds at the bag's end (live, it would hold them too).
  counts_.unpaired = counts_.left + counts_.right - 2 * counts_.pairs;
  if (!left_info_ || !right_info_) {
    counts_.no_camera_info += waiting_.size();
    waiting_.clear();
    return;
  }
  trackReadyPairs(true);
}

void BagStereoTracker::restartIfTimeJumped(int stream, const ros::Time& stamp) {
  if (!time_jumps_.jumpedBack(stream, stamp.toSec())) return;
  ++counts_.time_jump_resets;
  std::cerr << "track_stereo_bag: " << (stream == 0 ? "the images" : "the twist") << " went back "
            << time_jumps_.lastJump() << " s in time: tracking starts again at " << std::fixed
            << stamp.toSec() << "\n";
  if (tracker_) tracker_->reset();
  waiting_.clear();
  twists_.clear();
  prev_stamp_ = -1.0;
}

void BagStereoTracker::say(uint64_t* counter, const std::string& what) {
  ++*counter;
  if (*counter <= kRefusalsSaid) {
    std::cerr << "track_stereo_bag: " << what
              << (*counter == kRefusalsSaid ? " (the next ones of this kind counted only)" : "")
              << "\n";
  }
}

void BagStereoTracker::refuse(const std::string& why, double stamp) {
  say(&counts_.refused, "pair at " + stampText(stamp) + ": " + why + ": skipped");
}

std::optional<CameraMotionPrior> BagStereoTracker::motionPrior(const std::string& camera_frame,
                                                               double to) {
  if (!ros_options_.use_twist || twists_.empty() || prev_stamp_ <= 0 || to <= prev_stamp_) {
    return std::nullopt;
  }
  Eigen::Isometry3d cam_T_imu;
  std::string error;
  if (!lookupStaticTransform(static_transforms_, camera_frame, twist_frame_, &cam_T_imu, &error)) {
    return std::nullopt;  // as the node: no transform, no prediction
  }
  return motionPriorFromTwists(twists_, cam_T_imu.matrix(), prev_stamp_, to);
}

void BagStereoTracker::track(const Pair& pair) {
  const double stamp = pair.left->header.stamp.toSec();
  if (prev_stamp_ > 0 && stamp <= prev_stamp_) return refuse("stamp not after the last", stamp);
  if (!dueForTracking(stamp, prev_stamp_, options_.max_rate_hz)) return;
  cv::Mat left, right;
  StereoCalibration stereo;
  std::string why;
  if (!toGrayPair(pair.left, pair.right, &image_scale_, &left, &right, &why) ||
      pairCalibration(*left_info_, *right_info_, *pair.left, &stereo, &why) !=
          PairCalibration::kOk) {
    return refuse(why, stamp);
  }
  if (image_scale_.changed()) std::cerr << "track_stereo_bag: " << image_scale_.describe() << "\n";
  if (!tracker_ || !sameRectifiedPair(stereo, stereo_)) {
    const uint32_t first_id = tracker_ ? tracker_->nextId() : 0;
    tracker_ = std::make_unique<StereoTracker>(options_, stereo, masks_, first_id);
    stereo_ = stereo;
    prev_stamp_ = -1.0;
  }
  std_msgs::Header header = pair.left->header;
  if (ros_options_.rectify && !rectifyPair(&left, &right, &header)) return;
  const std::optional<CameraMotionPrior> prior = motionPrior(header.frame_id, stamp);
  StereoFrame frame;
  if (!tracker_->process(left, right, stamp, prior ? &*prior : nullptr, &frame, &why)) {
    return refuse(why, stamp);
  }
  prev_stamp_ = stamp;
  ++counts_.tracked;
  if (prior) ++counts_.twist_predicted;
  counts_.observations += frame.features.size();
  if (frame.features.empty()) {
    say(&counts_.without_features,
        "pair at " + stampText(stamp) + " gave no feature (" + kNoFeatureHint + ")");
  }
  if (const std::string hint = tracker_->rigCheck().hint(); !rig_warned_ && !hint.empty()) {
    std::cerr << "track_stereo_bag: warning from pair " << counts_.tracked - 1 << ": " << hint
              << "\n";
    rig_warned_ = true;
  }
  if (!debug_dir_.empty()) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06llu.png",
                  static_cast<unsigned long long>(counts_.tracked - 1));
    cv::imwrite(debug_dir_ + name, drawStereoTracks(left, right, frame, masks_));
  }
  out_->write(topics_.features, now_, featureMessage(header, left_info_->header.frame_id, frame));
}

bool BagStereoTracker::rectifyPair(cv::Mat* left, cv::Mat* right, std_msgs::Header* header) {
  std::string why;
  std::optional<geometry_msgs::TransformStamped> new_transform;
  const double stamp = header->stamp.toSec();
  if (rectifier_.rectify(*left_info_, *right_info_, left, right, header, &new_transform, &why) !=
      StereoPairRectifier::Result::kOk) {
    refuse(why, stamp);
    return false;
  }
  counts_.rectify_ms.push_back(rectifier_.rectifyMsLast());
  if (new_transform) {
    // As the node: the rectified frame's static tf, for the motion prior now and in the bag.
    static_transforms_.erase(
        std::remove_if(
            static_transforms_.begin(), static_transforms_.end(),
            [&](const auto& t) { return t.child_frame_id == new_transform->child_frame_id; }),
        static_transforms_.end());
    static_transforms_.push_back(*new_transform);
    tf2_msgs::TFMessage message;
    message.transforms.push_back(*new_transform);
    out_->write(topics_.tf_static, now_, message);
  }
  return true;
}

}  // namespace ekf_vislam
