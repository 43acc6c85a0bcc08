// track_stereo_bag: the stereo tracker over a recorded bag, without a roscore. It reads the
// rectified image pairs, their camera_info, the twist and /tf_static in bag order, tracks each
// pair as stereo_tracker_node does live (the same options, the same wait for the twist that
// reaches a pair's stamp, the same motion prior) and writes a bag of every message but the
// images, plus stereo/features. vislam_offline takes that bag:
//
//   rosrun ekf_vislam track_stereo_bag --bag robot.bag --out features.bag [--config tracker.yaml]
//   rosrun ekf_vislam vislam_offline --bag features.bag --out DIR
#include "ekf_vislam/core/time_jump_detector.h"
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/ros/bag_reader.h"
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/ros/feature_message.h"
#include "ekf_vislam/ros/gray_image.h"
#include "ekf_vislam/tracker/debug_drawing.h"
#include "ekf_vislam/tracker/frame_rate_limit.h"
#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/rectified_stereo.h"
#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/tracker_options.h"
#include "ekf_vislam/tracker/twist_motion_prior.h"

#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <exception>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace {

using namespace ekf_vislam;

constexpr uint64_t kRefusalsSaid = 10;  // refused pairs said one by one, the rest counted

const char* kUsage =
    "usage: track_stereo_bag --bag IN.bag --out OUT.bag [--config tracker.yaml] [--no-twist]\n"
    "                        [--debug-dir DIR] [--left-topic T] [--right-topic T]\n"
    "                        [--left-info-topic T] [--right-info-topic T] [--twist-topic T]\n"
    "                        [--features-topic T]\n"
    "Tracks the rectified stereo pairs of a bag as stereo_tracker_node does live and writes\n"
    "OUT.bag: every message of IN.bag but the images, plus the features (StereoFeatureArray on\n"
    "--features-topic, default /stereo/features), each written where the node would have\n"
    "published it (after the twist that reaches its pair's stamp). `vislam_offline --bag\n"
    "OUT.bag` then runs the estimator. Topics default to those of stereo_vislam.launch\n"
    "(/stereo/left/image_rect, /stereo/right/image_rect, /stereo/{left,right}/camera_info,\n"
    "/imu/twist: TwistStamped, TwistWithCovarianceStamped or Odometry); the twist's frame is\n"
    "found in /tf_static. --config: config/tracker.yaml's keys (absent: the defaults), the ros/\n"
    "group included (max_stamp_difference, use_twist; --no-twist sets use_twist false).\n"
    "--debug-dir: the debug drawing of every tracked pair as DIR/NNNNNN.png (stereo/debug_image).\n"
    "Images: sensor_msgs/Image (mono8, bgr8, rgb8...) or sensor_msgs/CompressedImage (png,\n"
    "jpeg: decoded as image_transport's compressed subscriber decodes them; give the topic,\n"
    "e.g. --left-topic /stereo/left/image_rect/compressed).\n";

struct Arguments {
  std::string bag, out, config, debug_dir;
  bool no_twist = false;
  std::string left = "/stereo/left/image_rect", right = "/stereo/right/image_rect";
  std::string left_info = "/stereo/left/camera_info", right_info = "/stereo/right/camera_info";
  std::string twist = "/imu/twist", features = "/stereo/features", tf_static = "/tf_static";
};

bool parseArguments(int argc, char** argv, Arguments* args, std::string* error) {
  const std::map<std::string, std::string*> values = {{"--bag", &args->bag},
                                                      {"--out", &args->out},
                                                      {"--config", &args->config},
                                                      {"--debug-dir", &args->debug_dir},
                                                      {"--left-topic", &args->left},
                                                      {"--right-topic", &args->right},
                                                      {"--left-info-topic", &args->left_info},
                                                      {"--right-info-topic", &args->right_info},
                                                      {"--twist-topic", &args->twist},
                                                      {"--features-topic", &args->features}};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = values.find(arg);
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--no-twist") {
      args->no_twist = true;
    } else if (value != values.end() && i + 1 < argc) {
      *value->second = argv[++i];
    } else {
      *error = "unknown or incomplete argument " + arg;
      return false;
    }
  }
  if (args->bag.empty() || args->out.empty()) *error = "--bag and --out are required";
  return error->empty();
}

bool loadOptions(const Arguments& args, TrackerOptions* options,
                 StereoTrackerRosOptions* ros_options, std::string* error) {
  if (!args.config.empty()) {
    YamlParameterSource source(args.config);
    if (!source.ok()) {
      *error = source.error();
      return false;
    }
    if (!parseTrackerOptions(source, options, error) ||
        !parseTrackerRosOptions(source, ros_options, error)) {
      return false;
    }
    const std::string unknown = unknownTrackerKeys(source);
    if (!unknown.empty())
      std::cerr << "track_stereo_bag: " << args.config << ": " << unknown << "\n";
  }
  if (args.no_twist) ros_options->use_twist = false;
  *error = options->validate();
  return error->empty();
}

/// What the pass counted, printed at the end.
struct Counts {
  uint64_t left = 0, right = 0, unpaired = 0, tracked = 0, refused = 0, observations = 0;
  uint64_t no_camera_info = 0;  ///< pairs dropped for want of camera_info
  uint64_t twist_predicted = 0;
  uint64_t time_jump_resets = 0;
  uint64_t without_features = 0;  ///< tracked pairs that gave no feature
  uint64_t undecodable = 0;       ///< compressed images that could not be decoded
};

/// The stereo_tracker_node's tracking thread, fed from a bag in bag order.
class BagStereoTracker {
 public:
  BagStereoTracker(const Arguments& args, const TrackerOptions& options,
                   const StereoTrackerRosOptions& ros_options, const StereoMasks& masks,
                   bool bag_has_twist, rosbag::Bag* out)
      : args_(args),
        options_(options),
        ros_options_(ros_options),
        masks_(masks),
        wait_for_twist_(ros_options.use_twist && bag_has_twist),
        out_(out),
        time_jumps_(ros_options.time_jump_reset, 2) {}

  void add(const rosbag::MessageInstance& m);
  /// The bag has ended: the pairs still waiting for the twist are tracked (live, their wait
  /// would run out).
  void finish();
  const Counts& counts() const { return counts_; }

 private:
  struct Pair {
    sensor_msgs::ImageConstPtr left, right;
  };
  void addImage(const sensor_msgs::ImageConstPtr& image, bool is_left);
  void addTwist(const ros::Time& stamp, const geometry_msgs::Twist& twist,
                const std::string& frame);
  void trackReadyPairs(bool all);
  void track(const Pair& pair);
  bool calibration(const sensor_msgs::Image& left, StereoCalibration* stereo, std::string* why);
  std::optional<CameraMotionPrior> motionPrior(const std::string& camera_frame, double to);
  void refuse(const std::string& why, double stamp);
  /// As the node: a stamp on `stream` (0 images, 1 twist) that went back in time (a bag played
  /// again) drops every track, waiting pair and twist, and tracking starts again, ids going on.
  void restartIfTimeJumped(int stream, const ros::Time& stamp);

  const Arguments& args_;
  const TrackerOptions& options_;
  const StereoTrackerRosOptions& ros_options_;
  const StereoMasks& masks_;
  const bool wait_for_twist_;
  rosbag::Bag* out_;
  TimeJumpDetector time_jumps_;
  ros::Time now_;  ///< bag time of the message being handled: where features are written
  std::deque<sensor_msgs::ImageConstPtr> lefts_, rights_;
  std::deque<Pair> waiting_;
  std::deque<StampedTwist> twists_;
  std::string twist_frame_;
  std::vector<geometry_msgs::TransformStamped> static_transforms_;
  sensor_msgs::CameraInfoConstPtr left_info_, right_info_;
  std::unique_ptr<StereoTracker> tracker_;
  StereoCalibration stereo_;
  double prev_stamp_ = -1.0;
  bool rig_warned_ = false;
  Counts counts_;
};

void BagStereoTracker::add(const rosbag::MessageInstance& m) {
  now_ = m.getTime();
  const std::string& topic = m.getTopic();
  if (topic == args_.left || topic == args_.right) {
    sensor_msgs::ImageConstPtr image = m.instantiate<sensor_msgs::Image>();
    if (!image) {
      if (const auto compressed = m.instantiate<sensor_msgs::CompressedImage>()) {
        std::string why;
        image = decompressedImage(*compressed, &why);
        if (!image && ++counts_.undecodable <= kRefusalsSaid) {
          std::cerr << "track_stereo_bag: " << topic << " at " << std::fixed
                    << compressed->header.stamp.toSec() << ": " << why << ": skipped\n";
        }
      }
    }
    if (image) addImage(image, topic == args_.left);
    return;
  }
  out_->write(topic, m.getTime(), m, m.getConnectionHeader());
  if (topic == args_.left_info) {
    left_info_ = m.instantiate<sensor_msgs::CameraInfo>();
  } else if (topic == args_.right_info) {
    right_info_ = m.instantiate<sensor_msgs::CameraInfo>();
  } else if (topic == args_.tf_static) {
    if (const auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
      static_transforms_.insert(static_transforms_.end(), tf->transforms.begin(),
                                tf->transforms.end());
    }
  } else if (topic == args_.twist) {
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

void BagStereoTracker::addImage(const sensor_msgs::ImageConstPtr& image, bool is_left) {
  ++(is_left ? counts_.left : counts_.right);
  (is_left ? lefts_ : rights_).push_back(image);
  // Pair the oldest of each side when their stamps agree; an image older than the other side's
  // oldest has no partner (the synchronizer drops it alike).
  while (!lefts_.empty() && !rights_.empty()) {
    const double apart = (lefts_.front()->header.stamp - rights_.front()->header.stamp).toSec();
    if (std::abs(apart) <= ros_options_.max_stamp_difference) {
      restartIfTimeJumped(0, lefts_.front()->header.stamp);
      waiting_.push_back({lefts_.front(), rights_.front()});
      lefts_.pop_front();
      rights_.pop_front();
    } else {
      std::deque<sensor_msgs::ImageConstPtr>& older = apart < 0 ? lefts_ : rights_;
      if (++counts_.unpaired <= kRefusalsSaid) {
        std::cerr << "track_stereo_bag: " << (apart < 0 ? "left" : "right") << " image at "
                  << std::fixed << older.front()->header.stamp.toSec()
                  << " has no partner within ros/max_stamp_difference: skipped\n";
      }
      older.pop_front();
    }
  }
  trackReadyPairs(false);
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
  counts_.unpaired += lefts_.size() + rights_.size();  // images the bag ends on, without a partner
  lefts_.clear();
  rights_.clear();
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

void BagStereoTracker::refuse(const std::string& why, double stamp) {
  ++counts_.refused;
  if (counts_.refused <= kRefusalsSaid) {
    std::cerr << "track_stereo_bag: pair at " << std::fixed << stamp << ": " << why << ": skipped"
              << (counts_.refused == kRefusalsSaid ? " (the next ones counted only)" : "") << "\n";
  }
}

bool BagStereoTracker::calibration(const sensor_msgs::Image& left, StereoCalibration* stereo,
                                   std::string* why) {
  if (!ros_conversions::calibrationFromCameraInfo(*left_info_, *right_info_, stereo, why)) {
    *why = "camera_info refused: " + *why;
    return false;
  }
  if ((left_info_->width != 0 && left_info_->width != left.width) ||
      (left_info_->height != 0 && left_info_->height != left.height)) {
    *why = "image size differs from its camera_info's";
    return false;
  }
  return true;
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
  if (!toGrayImage(pair.left, &left, &why) || !toGrayImage(pair.right, &right, &why) ||
      !calibration(*pair.left, &stereo, &why)) {
    return refuse(why, stamp);
  }
  if (!tracker_ || !sameRectifiedPair(stereo, stereo_)) {
    const uint32_t first_id = tracker_ ? tracker_->nextId() : 0;
    tracker_ = std::make_unique<StereoTracker>(options_, stereo, masks_, first_id);
    stereo_ = stereo;
    prev_stamp_ = -1.0;
  }
  const std::optional<CameraMotionPrior> prior = motionPrior(pair.left->header.frame_id, stamp);
  StereoFrame frame;
  if (!tracker_->process(left, right, stamp, prior ? &*prior : nullptr, &frame, &why)) {
    return refuse(why, stamp);
  }
  prev_stamp_ = stamp;
  ++counts_.tracked;
  if (prior) ++counts_.twist_predicted;
  counts_.observations += frame.features.size();
  if (frame.features.empty() && ++counts_.without_features <= kRefusalsSaid) {
    std::cerr << "track_stereo_bag: pair at " << std::fixed << stamp << " gave no feature ("
              << kNoFeatureHint << ")\n";
  }
  if (const std::string hint = tracker_->rigCheck().hint(); !rig_warned_ && !hint.empty()) {
    std::cerr << "track_stereo_bag: warning from pair " << counts_.tracked - 1 << ": " << hint
              << "\n";
    rig_warned_ = true;
  }
  if (!args_.debug_dir.empty()) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06llu.png",
                  static_cast<unsigned long long>(counts_.tracked - 1));
    cv::imwrite(args_.debug_dir + name, drawStereoTracks(left, right, frame, masks_));
  }
  out_->write(args_.features, now_,
              featureMessage(pair.left->header, left_info_->header.frame_id, frame));
}

/// The image topics hold sensor_msgs/Image or CompressedImage; *has_twist: the bag has the twist
/// topic.
bool checkTopics(const Arguments& args, rosbag::View& view, bool* has_twist, std::string* error) {
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) types[c->topic] = c->datatype;
  *has_twist = types.count(args.twist) > 0;
  for (const std::string& topic : {args.left, args.right}) {
    const auto type = types.find(topic);
    if (type == types.end()) {
      std::string images;
      for (const auto& [name, datatype] : types) {
        if (datatype.rfind("sensor_msgs/", 0) == 0 && datatype.find("Image") != std::string::npos)
          images += " " + name + " (" + datatype + ")";
      }
      *error = "no " + topic + " (--left-topic, --right-topic); its image topics:" +
               (images.empty() ? std::string(" none") : images);
      return false;
    }
    if (type->second != "sensor_msgs/Image" && type->second != "sensor_msgs/CompressedImage") {
      *error = topic + " holds " + type->second + ", not sensor_msgs/Image or CompressedImage";
      return false;
    }
  }
  return true;
}

int run(int argc, char** argv) {
  Arguments args;
  TrackerOptions options;
  StereoTrackerRosOptions ros_options;
  StereoMasks masks;
  std::string error;
  if (!parseArguments(argc, argv, &args, &error) ||
      !loadOptions(args, &options, &ros_options, &error) ||
      !loadStereoMasks(options, &masks, &error)) {
    std::cerr << "track_stereo_bag: " << error << "\n" << kUsage;
    return 2;
  }
  rosbag::Bag in(args.bag, rosbag::bagmode::Read);
  rosbag::View view(in);
  bool has_twist = false;
  if (!checkTopics(args, view, &has_twist, &error)) {
    std::cerr << "track_stereo_bag: " << args.bag << ": " << error << "\n";
    return 2;
  }
  rosbag::Bag out(args.out, rosbag::bagmode::Write);
  BagStereoTracker tracker(args, options, ros_options, masks, has_twist, &out);
  for (const rosbag::MessageInstance& m : view) tracker.add(m);
  tracker.finish();
  out.close();
  const Counts& c = tracker.counts();
  std::cout << "track_stereo_bag: " << c.left << " left and " << c.right << " right images, "
            << c.unpaired << " without a partner, " << c.undecodable << " not decodable; "
            << c.tracked << " pairs tracked (" << c.twist_predicted << " predicted from the twist, "
            << c.without_features << " without a feature), " << c.refused << " refused, "
            << c.no_camera_info << " dropped without camera_info, " << c.time_jump_resets
            << " restarts (time went back); observations per pair "
            << (c.tracked ? static_cast<double>(c.observations) / c.tracked : 0.0) << " -> "
            << args.out << "\n";
  if (c.tracked == 0) {
    std::cerr << "track_stereo_bag: no pair tracked"
              << (c.no_camera_info > 0 ? ": the bag has no camera_info pair on --left-info-topic "
                                         "and --right-info-topic"
                                       : "")
              << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "track_stereo_bag: " << e.what() << std::endl;
    return 1;
  }
}
