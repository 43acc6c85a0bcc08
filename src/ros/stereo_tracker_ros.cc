#include "ekf_vislam/ros/stereo_tracker_ros.h"

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/ros/feature_message.h"
#include "ekf_vislam/ros/gray_image.h"
#include "ekf_vislam/ros/ros_parameter_source.h"
#include "ekf_vislam/tracker/debug_drawing.h"
#include "ekf_vislam/tracker/frame_rate_limit.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <cv_bridge/cv_bridge.h>
#include <ekf_vislam/StereoFeatureArray.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ekf_vislam {

namespace {

constexpr double kWarnPeriod = 5.0;          // s, throttle of the bad-input warnings
constexpr double kCameraInfoPatience = 1.0;  // s of image time pairs wait before a warning
// Feature messages a subscriber in another process (the estimator run standalone, a recorder)
// may fall behind before the oldest is dropped: minutes of a camera's rate, a few kB each.
constexpr int kFeatureQueue = 2000;
constexpr const char* kNoCameraInfo =
    "no camera_info yet on stereo/left/camera_info and stereo/right/camera_info";

// The camera_info's binning and region of interest, when it has either ("" otherwise), for the
// log line of a new calibration.
std::string binningAndRoi(const sensor_msgs::CameraInfo& info) {
  std::string text;
  if (info.binning_x > 1 || info.binning_y > 1) {
    text += ", binning " + std::to_string(std::max(1u, info.binning_x)) + "x" +
            std::to_string(std::max(1u, info.binning_y));
  }
  const sensor_msgs::RegionOfInterest& roi = info.roi;
  if (roi.x_offset != 0 || roi.y_offset != 0 || roi.width != 0 || roi.height != 0) {
    text += ", roi " + std::to_string(roi.width) + "x" + std::to_string(roi.height) + " at (" +
            std::to_string(roi.x_offset) + ", " + std::to_string(roi.y_offset) + ")";
  }
  return text.empty() ? text : " (camera_info" + text + ")";
}

}  // namespace

StereoTrackerRos::StereoTrackerRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh,
                                   const std::string& name)
    : nh_(nh), pnh_(pnh), name_(name), image_transport_(nh) {
  RosParameterSource source(pnh_);
  std::string error;
  if (!parseTrackerOptions(source, &options_, &error) || !(error = options_.validate()).empty() ||
      !loadStereoMasks(options_, &masks_, &error) ||
      !parseTrackerRosOptions(source, &ros_options_, &error)) {
    ROS_FATAL("%s: invalid parameters: %s", name_.c_str(), error.c_str());
    throw std::runtime_error("invalid parameters: " + error);
  }
  const std::string unknown = unknownTrackerKeys(source);
  if (!unknown.empty()) {
    ROS_WARN("%s: %s: %s", name_.c_str(), source.describe().c_str(), unknown.c_str());
  }
  ROS_INFO("%s: tracker options (from %s):\n%s", name_.c_str(), source.describe().c_str(),
           describeOptions(options_).c_str());
  time_jumps_ = TimeJumpDetector(ros_options_.time_jump_reset, 2);
  image_scale_ = DeepImageScale(ros_options_.image_bits);

  features_pub_ = nh_.advertise<ekf_vislam::StereoFeatureArray>("stereo/features", kFeatureQueue);
  debug_pub_ = image_transport_.advertise("stereo/debug_image", 1);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);

  diagnostics_ = std::make_unique<PeriodicDiagnostics>(nh_, pnh_, name_, "stereo tracker",
                                                       ros_options_.diagnostic_period, this,
                                                       &StereoTrackerRos::produceDiagnostics);
  wait_timer_ = nh_.createWallTimer(ros::WallDuration(0.1), &StereoTrackerRos::waitTimer, this);

  diagnostics_cache_.level = diagnostic_msgs::DiagnosticStatus::WARN;
  diagnostics_cache_.message = "tracking: the counters come after the pair being tracked";
  tracking_thread_ = std::thread(&StereoTrackerRos::trackingThread, this);
  const int queue = ros_options_.queue_size;
  left_info_sub_ =
      nh_.subscribe("stereo/left/camera_info", queue, &StereoTrackerRos::leftInfoCallback, this);
  right_info_sub_ =
      nh_.subscribe("stereo/right/camera_info", queue, &StereoTrackerRos::rightInfoCallback, this);
  if (ros_options_.use_twist) {
    if (ros_options_.twist_type == TwistMessageType::kOdometry) {
      twist_sub_ =
          nh_.subscribe("imu/twist", 20 * queue, &StereoTrackerRos::odometryTwistCallback, this);
    } else if (ros_options_.twist_type == TwistMessageType::kTwistWithCovariance) {
      twist_sub_ = nh_.subscribe("imu/twist", 20 * queue,
                                 &StereoTrackerRos::twistWithCovarianceCallback, this);
    } else {
      twist_sub_ = nh_.subscribe("imu/twist", 20 * queue, &StereoTrackerRos::twistCallback, this);
    }
  }
  subscribeImages();
}

void StereoTrackerRos::subscribeImages() {
  const int queue = ros_options_.queue_size;
  // ros/rectify: the cameras' raw images, rectified here.
  const std::string image = ros_options_.rectify ? "image_raw" : "image_rect";
  const std::string left_base = "stereo/left/" + image, right_base = "stereo/right/" + image;
  if (ros_options_.image_transport == ImageTransportType::kRaw) {
    left_sub_.subscribe(nh_, left_base, queue);
    right_sub_.subscribe(nh_, right_base, queue);
    sync_ = makeStereoImageSync<sensor_msgs::Image>(ros_options_);
    sync_->connectInput(left_sub_, right_sub_);
    sync_->registerCallback(&StereoTrackerRos::imageCallback, this);
    return;
  }
  // As image_transport names a transport's topic: the base topic resolved (remappings applied),
  // then /compressed.
  const std::string left = nh_.resolveName(left_base) + "/compressed";
  const std::string right = nh_.resolveName(right_base) + "/compressed";
  left_compressed_sub_.subscribe(nh_, left, queue);
  right_compressed_sub_.subscribe(nh_, right, queue);
  compressed_sync_ = makeStereoImageSync<sensor_msgs::CompressedImage>(ros_options_);
  compressed_sync_->connectInput(left_compressed_sub_, right_compressed_sub_);
  compressed_sync_->registerCallback(&StereoTrackerRos::compressedImageCallback, this);
  ROS_INFO("%s: compressed images on %s and %s (ros/image_transport)", name_.c_str(), left.c_str(),
           right.c_str());
}

StereoTrackerRos::~StereoTrackerRos() {
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    stopping_ = true;
  }
  inbox_cv_.notify_all();
  if (tracking_thread_.joinable()) tracking_thread_.join();
}

bool StereoTrackerRos::post(std::function<void()> event, size_t image_bytes) {
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    if (stopping_) return false;
    if (image_bytes > 0 && !inbox_.empty() &&
        inbox_image_bytes_ + image_bytes > ros_options_.max_backlog_mb * 1e6) {
      ++pairs_dropped_backlog_;
      ROS_WARN_THROTTLE(kWarnPeriod,
                        "%s: tracking is behind by %lu events and %.0f MB of images "
                        "(ros/max_backlog_mb): the new pair is dropped (%lu so far)",
                        name_.c_str(), inbox_.size(), inbox_image_bytes_ / 1e6,
                        pairs_dropped_backlog_);
      return false;
    }
    inbox_image_bytes_ += image_bytes;
    peak_backlog_bytes_ = std::max(peak_backlog_bytes_, inbox_image_bytes_);
    inbox_.push_back({std::move(event), image_bytes, steadyClockSeconds()});
  }
  inbox_cv_.notify_one();
  return true;
}

void StereoTrackerRos::trackingThread() {
  std::unique_lock<std::mutex> inbox_lock(inbox_mutex_);
  for (;;) {
    inbox_cv_.wait(inbox_lock, [this] { return stopping_ || !inbox_.empty(); });
    if (stopping_) return;
    InboxEvent event = std::move(inbox_.front());
    inbox_.pop_front();
    inbox_lock.unlock();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      event_arrival_ = event.arrival;
      try {
        event.run();
      } catch (const std::exception& e) {  // (OpenCV, cv_bridge) the thread and the node go on
        ++tracker_refused_;
        ROS_ERROR_THROTTLE(kWarnPeriod, "%s: %s: input skipped (%lu refused so far)", name_.c_str(),
                           e.what(), tracker_refused_);
      }
      cacheDiagnosticsIfRequested();
    }
    inbox_lock.lock();
    inbox_image_bytes_ -= event.image_bytes;
  }
}

void StereoTrackerRos::leftInfoCallback(const sensor_msgs::CameraInfoConstPtr& msg) {
  post([this, msg] {
    left_info_ = msg;
    processReadyPairs();
  });
}

void StereoTrackerRos::rightInfoCallback(const sensor_msgs::CameraInfoConstPtr& msg) {
  post([this, msg] {
    right_info_ = msg;
    processReadyPairs();
  });
}

void StereoTrackerRos::twistCallback(const geometry_msgs::TwistStampedConstPtr& msg) {
  addTwist(msg->header.stamp, msg->twist, msg->header.frame_id);
}

void StereoTrackerRos::twistWithCovarianceCallback(
    const geometry_msgs::TwistWithCovarianceStampedConstPtr& msg) {
  addTwist(msg->header.stamp, msg->twist.twist, msg->header.frame_id);
}

void StereoTrackerRos::odometryTwistCallback(const nav_msgs::OdometryConstPtr& msg) {
  // The twist of child_frame_id; its rotation is what the KLT prediction uses.
  addTwist(msg->header.stamp, msg->twist.twist, msg->child_frame_id);
}

void StereoTrackerRos::addTwist(const ros::Time& ros_stamp, const geometry_msgs::Twist& twist,
                                const std::string& frame) {
  post([this, ros_stamp, twist, frame] { receiveTwist(ros_stamp, twist, frame); });
}

void StereoTrackerRos::receiveTwist(const ros::Time& ros_stamp, const geometry_msgs::Twist& t,
                                    const std::string& frame) {
  restartIfTimeJumped(1, ros_stamp);
  const StampedTwist sample{ros_stamp.toSec(), Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z),
                            Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z)};
  if (!keepTwist(sample, prev_stamp_, &twists_)) return;
  twist_frame_ = frame;
  processReadyPairs();
}

bool StereoTrackerRos::restartIfTimeJumped(int stream, const ros::Time& stamp) {
  if (!time_jumps_.jumpedBack(stream, stamp.toSec())) return false;
  ++time_jump_resets_;
  ROS_WARN(
      "%s: %s went back %.3f s in time (a bag played again?): tracking starts again at "
      "%.3f s (%lu so far)",
      name_.c_str(), stream == 0 ? "the images" : "imu/twist", time_jumps_.lastJump(),
      stamp.toSec(), static_cast<unsigned long>(time_jump_resets_));
  if (tracker_) tracker_->reset();
  pair_gaps_.reset();
  waiting_pairs_.clear();
  twists_.clear();
  prev_stamp_ = -1;
  return true;
}

bool StereoTrackerRos::pairReady(const ImagePair& pair, double now) const {
  if (!hasCameraInfo()) return false;
  if (!ros_options_.use_twist) return true;
  // No twist yet: wait for it only when imu/twist has a publisher (a stream about to start, such
  // as a bag's or a driver's that comes up a moment after the camera's).
  if (twists_.empty() && twist_sub_.getNumPublishers() == 0) return true;
  const ros::Time& stamp = pair.left->header.stamp;
  if (!twists_.empty() && twists_.back().stamp >= stamp.toSec()) return true;
  return lateStreamWaitIsOver((waiting_pairs_.back().left->header.stamp - stamp).toSec(),
                              now - pair.arrival, ros_options_.max_twist_wait);
}

void StereoTrackerRos::waitTimer(const ros::WallTimerEvent&) {
  // One check at a time in the inbox: a busy tracking thread does not collect a tick per 0.1 s.
  if (tick_posted_.exchange(true)) return;
  post([this] {
    tick_posted_ = false;
    if (!waiting_pairs_.empty()) processReadyPairs();
  });
}

void StereoTrackerRos::processReadyPairs() {
  const double now = event_arrival_;
  while (!waiting_pairs_.empty() && pairReady(waiting_pairs_.front(), now)) {
    const ImagePair pair = waiting_pairs_.front();
    waiting_pairs_.pop_front();
    trackPair(pair);
  }
  // Without camera_info nothing can be tracked: keep the newest pairs only.
  while (waiting_pairs_.size() > static_cast<size_t>(ros_options_.queue_size)) {
    waiting_pairs_.pop_front();
    ++pairs_dropped_waiting_;
    if (!hasCameraInfo()) ++missing_camera_info_;
    ROS_WARN_THROTTLE(
        kWarnPeriod, "%s: %s: oldest waiting pair dropped (%lu so far)", name_.c_str(),
        hasCameraInfo() ? "ros/queue_size pairs wait for the twist stream" : kNoCameraInfo,
        pairs_dropped_waiting_);
  }
  if (!hasCameraInfo() && !waiting_pairs_.empty()) {
    const double waited =
        (waiting_pairs_.back().left->header.stamp - waiting_pairs_.front().left->header.stamp)
            .toSec();
    if (waited >= kCameraInfoPatience) {
      ROS_WARN_THROTTLE(kWarnPeriod,
                        "%s: %s: %lu pairs wait (the oldest for %.1f s of image time); more "
                        "than ros/queue_size are dropped",
                        name_.c_str(), kNoCameraInfo, waiting_pairs_.size(), waited);
    }
  }
}

void StereoTrackerRos::noteMissingPairs(double stamp) {
  const int missing = pair_gaps_.add(stamp);
  if (missing == 0) return;
  ROS_WARN_THROTTLE(kWarnPeriod,
                    "%s: %s: the camera dropped frames, the stream paused, or this node's input "
                    "queue overflowed because tracking is slower than the images (see "
                    "track_ms_last in /diagnostics)",
                    name_.c_str(),
                    pair_gaps_.describeMissing(missing, stamp, "stereo pair").c_str());
}

bool StereoTrackerRos::wellFormed(const sensor_msgs::Image& left, const sensor_msgs::Image& right) {
  const double apart = std::abs((left.header.stamp - right.header.stamp).toSec());
  if (apart > ros_options_.max_stamp_difference) {
    ++unsynchronized_;
    ROS_WARN_THROTTLE(kWarnPeriod,
                      "%s: left and right images %.4f s apart (more than "
                      "ros/max_stamp_difference): pair skipped (%lu so far)",
                      name_.c_str(), apart, unsynchronized_);
    return false;
  }
  for (const sensor_msgs::Image* image : {&left, &right}) {
    if (!isTrackableEncoding(image->encoding)) {
      ++bad_encoding_;
      ROS_WARN_THROTTLE(kWarnPeriod, "%s: encoding '%s' (expected %s): pair skipped (%lu so far)",
                        name_.c_str(), image->encoding.c_str(), kTrackableEncodings, bad_encoding_);
      return false;
    }
  }
  if (left.width != right.width || left.height != right.height) {
    ++size_mismatch_;
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: left image %ux%u, right %ux%u: pair skipped (%lu so far)",
                      name_.c_str(), left.width, left.height, right.width, right.height,
                      size_mismatch_);
    return false;
  }
  return true;
}

bool StereoTrackerRos::calibrationFor(const sensor_msgs::Image& left, StereoCalibration* stereo,
                                      std::string* why) {
  if (!hasCameraInfo()) {
    ++missing_camera_info_;
    *why = kNoCameraInfo;
    return false;
  }
  const PairCalibration result = pairCalibration(*left_info_, *right_info_, left, stereo, why);
  if (result == PairCalibration::kCameraInfoRefused) ++bad_camera_info_;
  if (result == PairCalibration::kSizeMismatch) ++size_mismatch_;
  return result == PairCalibration::kOk;
}

std::optional<CameraMotionPrior> StereoTrackerRos::motionPrior(const std::string& camera_frame,
                                                               double from, double to) {
  if (twists_.empty() || from <= 0 || to <= from) return std::nullopt;
  Eigen::Isometry3d cam_T_imu;
  try {
    cam_T_imu =
        tf2::transformToEigen(tf_buffer_.lookupTransform(camera_frame, twist_frame_, ros::Time(0)));
  } catch (const tf2::TransformException&) {
    return std::nullopt;  // no tf between the twist and the camera: no prediction
  }
  return motionPriorFromTwists(twists_, cam_T_imu.matrix(), from, to);
}

void StereoTrackerRos::postPair(std::function<void()> event, size_t image_bytes, double stamp) {
  // Dropped from a full backlog (counted there): the pair did arrive, so its stamp leaves no gap
  // for pairs_missing, which counts what never came.
  if (!post(std::move(event), image_bytes)) post([this, stamp] { pair_gaps_.add(stamp); });
}

void StereoTrackerRos::imageCallback(const sensor_msgs::ImageConstPtr& left_msg,
                                     const sensor_msgs::ImageConstPtr& right_msg) {
  postPair([this, left_msg, right_msg] { receivePair(left_msg, right_msg); },
           left_msg->data.size() + right_msg->data.size(), left_msg->header.stamp.toSec());
}

void StereoTrackerRos::compressedImageCallback(
    const sensor_msgs::CompressedImageConstPtr& left_msg,
    const sensor_msgs::CompressedImageConstPtr& right_msg) {
  const double stamp = left_msg->header.stamp.toSec();
  postPair(
      [this, left_msg, right_msg, stamp] {
        // The right image decoded beside the left (3.6 ms each for a 1241x376 jpeg here).
        const double start = steadyClockSeconds();
        const DecompressedPair pair = decompressedPair(*left_msg, *right_msg);
        decode_ms_last_ = 1e3 * (steadyClockSeconds() - start);
        if (pair.left && pair.right) {
          receivePair(pair.left, pair.right);
          return;
        }
        ++pairs_received_;
        noteMissingPairs(stamp);  // it came: no gap
        undecodable_images_ +=
            static_cast<uint64_t>(!pair.left) + static_cast<uint64_t>(!pair.right);
        ROS_WARN_THROTTLE(
            kWarnPeriod, "%s: pair at %.3f: %s: pair skipped (%lu images so far)", name_.c_str(),
            stamp, (pair.left ? pair.why_right : pair.why_left).c_str(), undecodable_images_);
      },
      left_msg->data.size() + right_msg->data.size(), stamp);
}

void StereoTrackerRos::receivePair(const sensor_msgs::ImageConstPtr& left_msg,
                                   const sensor_msgs::ImageConstPtr& right_msg) {
  ++pairs_received_;
  restartIfTimeJumped(0, left_msg->header.stamp);
  noteMissingPairs(left_msg->header.stamp.toSec());
  if (!waiting_pairs_.empty() &&
      left_msg->header.stamp <= waiting_pairs_.back().left->header.stamp) {
    ++pairs_out_of_order_;
    ROS_WARN_THROTTLE(kWarnPeriod,
                      "%s: pair stamp %.4f not after the last one: pair skipped "
                      "(%lu so far)",
                      name_.c_str(), left_msg->header.stamp.toSec(), pairs_out_of_order_);
    return;
  }
  if (!wellFormed(*left_msg, *right_msg)) return;
  waiting_pairs_.push_back({left_msg, right_msg, event_arrival_});
  processReadyPairs();
}

void StereoTrackerRos::trackPair(const ImagePair& pair) {
  const sensor_msgs::ImageConstPtr& left_msg = pair.left;
  const sensor_msgs::ImageConstPtr& right_msg = pair.right;
  const double stamp = left_msg->header.stamp.toSec();
  if (prev_stamp_ > 0 && stamp <= prev_stamp_) {
    ++pairs_out_of_order_;
    ROS_WARN_THROTTLE(kWarnPeriod,
                      "%s: pair stamp %.4f not after the last tracked one: pair "
                      "skipped (%lu so far)",
                      name_.c_str(), stamp, pairs_out_of_order_);
    return;
  }
  // input/max_rate_hz: decided by the stamps alone, as track_stereo_images does (not a fault).
  if (!dueForTracking(stamp, prev_stamp_, options_.max_rate_hz)) {
    ++pairs_skipped_rate_;
    return;
  }
  cv::Mat left, right;
  std::string why;
  if (!toGrayPair(left_msg, right_msg, &image_scale_, &left, &right, &why)) {
    ++bad_encoding_;  // an encoding checked at arrival whose data cannot be read
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s: pair skipped (%lu so far)", name_.c_str(), why.c_str(),
                      bad_encoding_);
    return;
  }
  if (image_scale_.changed()) ROS_INFO("%s: %s", name_.c_str(), image_scale_.describe().c_str());
  StereoCalibration stereo;
  if (!calibrationFor(*left_msg, &stereo, &why)) {
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s: pair skipped", name_.c_str(), why.c_str());
    return;
  }
  if (!tracker_ || !sameRectifiedPair(stereo, stereo_)) {
    // A (new) calibration: the tracks restart, the ids go on (never used twice).
    const uint32_t first_id = tracker_ ? tracker_->nextId() : 0;
    tracker_ = std::make_unique<StereoTracker>(options_, stereo, masks_, first_id);
    stereo_ = stereo;
    prev_stamp_ = -1;
    ROS_INFO("%s: tracking %dx%d pairs: fx %.3f, fy %.3f, cx %.3f, cy %.3f, baseline %.4f m%s",
             name_.c_str(), stereo.image_width, stereo.image_height, stereo.fx, stereo.fy,
             stereo.cx, stereo.cy, stereo.baseline, binningAndRoi(*left_info_).c_str());
  }
  std_msgs::Header header = left_msg->header;
  if (ros_options_.rectify && !rectifyPair(&left, &right, &header)) return;
  std::optional<CameraMotionPrior> prior;
  if (ros_options_.use_twist) prior = motionPrior(header.frame_id, prev_stamp_, stamp);
  if (prior) ++twist_used_;
  StereoFrame frame;
  if (!tracker_->process(left, right, stamp, prior ? &*prior : nullptr, &frame, &why)) {
    ++tracker_refused_;
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s: pair skipped (%lu so far)", name_.c_str(), why.c_str(),
                      tracker_refused_);
    return;
  }
  prev_stamp_ = stamp;
  ++pairs_tracked_;
  if (frame.stats.predicted_from_first_matches) ++first_fit_predictions_;
  tracks_crowded_ += static_cast<uint64_t>(frame.stats.crowded);
  last_stats_ = frame.stats;
  if (frame.features.empty()) {
    ++pairs_without_features_;
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: pair at %.3f gave no feature (%s; %lu so far)",
                      name_.c_str(), stamp, kNoFeatureHint, pairs_without_features_);
  }
  if (const std::string hint = tracker_->rigCheck().hint(); !hint.empty()) {
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s", name_.c_str(), hint.c_str());
  }
  publish(header, left, right, frame);
}

bool StereoTrackerRos::rectifyPair(cv::Mat* left, cv::Mat* right, std_msgs::Header* header) {
  std::string why;
  std::optional<geometry_msgs::TransformStamped> new_transform;
  const StereoPairRectifier::Result result =
      rectifier_.rectify(*left_info_, *right_info_, left, right, header, &new_transform, &why);
  if (result != StereoPairRectifier::Result::kOk) {
    ++(result == StereoPairRectifier::Result::kSizeMismatch ? size_mismatch_ : bad_camera_info_);
    ROS_WARN_THROTTLE(kWarnPeriod, "%s: %s: pair skipped", name_.c_str(), why.c_str());
    return false;
  }
  if (new_transform) {
    // Into this node's own buffer at once (the motion prior looks it up now) and on /tf_static.
    tf_buffer_.setTransform(*new_transform, name_, true);
    if (!rectified_frame_broadcaster_) {
      rectified_frame_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    }
    rectified_frame_broadcaster_->sendTransform(*new_transform);
    ROS_INFO("%s: ros/rectify: features in %s, turned from %s by the left camera_info's R",
             name_.c_str(), new_transform->child_frame_id.c_str(),
             new_transform->header.frame_id.c_str());
  }
  return true;
}

void StereoTrackerRos::publish(const std_msgs::Header& header, const cv::Mat& left,
                               const cv::Mat& right, const StereoFrame& frame) {
  ekf_vislam::StereoFeatureArrayPtr msg = boost::make_shared<ekf_vislam::StereoFeatureArray>(
      featureMessage(header, left_info_ ? left_info_->header.frame_id : "", frame));
  features_pub_.publish(msg);  // shared pointer: no copy inside a nodelet manager
  if (debug_pub_.getNumSubscribers() > 0) {
    cv_bridge::CvImage debug(header, sensor_msgs::image_encodings::BGR8,
                             drawStereoTracks(left, right, frame, masks_));
    debug_pub_.publish(debug.toImageMsg());
  }
}

const StereoRigCheck& StereoTrackerRos::rigCheck() const {
  static const StereoRigCheck kNoPairYet(0.0);
  return tracker_ ? tracker_->rigCheck() : kNoPairYet;
}

void StereoTrackerRos::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  // Never wait for the tracking thread: while a backlog lasts it takes mutex_ again after each
  // pair, so this callback (and, on a one-threaded node, the images behind it in the ROS queue)
  // would wait for the whole backlog. Idle, it reads the values now; busy, it takes those the
  // tracking thread leaves after its current event.
  std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
  if (lock.owns_lock()) {
    fillDiagnostics(droppedFromBacklog(), status);
  } else {
    diagnostics_requested_ = true;
    std::lock_guard<std::mutex> cache_lock(diagnostics_cache_mutex_);
    status.level = diagnostics_cache_.level;
    status.message = diagnostics_cache_.message;
    status.values = diagnostics_cache_.values;
  }
  std::lock_guard<std::mutex> inbox_lock(inbox_mutex_);
  status.add("backlog_events", inbox_.size());
  status.add("backlog_mb", inbox_image_bytes_ / 1e6);
  status.add("backlog_mb_peak", peak_backlog_bytes_ / 1e6);
  status.add("pairs_dropped_backlog", pairs_dropped_backlog_);
}

void StereoTrackerRos::cacheDiagnosticsIfRequested() {
  if (!diagnostics_requested_.exchange(false)) return;
  diagnostic_updater::DiagnosticStatusWrapper status;
  fillDiagnostics(droppedFromBacklog(), status);
  std::lock_guard<std::mutex> cache_lock(diagnostics_cache_mutex_);
  diagnostics_cache_ = status;
}

uint64_t StereoTrackerRos::droppedFromBacklog() {
  std::lock_guard<std::mutex> inbox_lock(inbox_mutex_);
  return pairs_dropped_backlog_;
}

void StereoTrackerRos::fillDiagnostics(uint64_t dropped_from_backlog,
                                       diagnostic_updater::DiagnosticStatusWrapper& status) const {
  const uint64_t bad = bad_encoding_ + size_mismatch_ + unsynchronized_ + missing_camera_info_ +
                       bad_camera_info_ + tracker_refused_ + pairs_out_of_order_ +
                       pairs_dropped_waiting_ + pair_gaps_.missing() + dropped_from_backlog +
                       undecodable_images_;
  if (pairs_received_ == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no synchronized stereo pair yet");
  } else if (!hasCameraInfo()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR,
                   std::string(kNoCameraInfo) + ": pairs wait");
  } else if (pairs_tracked_ == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "no pair tracked (see counters)");
  } else if (const std::string hint = rigCheck().hint(); !hint.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, hint);
  } else if (last_stats_.published == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   std::string("the last pair gave no feature: ") + kNoFeatureHint);
  } else if (bad > 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "running; some pairs skipped");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "running");
  }
  status.add("pairs_received", pairs_received_);
  status.add("pairs_tracked", pairs_tracked_);
  status.add("bad_encoding", bad_encoding_);
  status.add("undecodable_images", undecodable_images_);
  status.add("size_mismatch", size_mismatch_);
  status.add("unsynchronized", unsynchronized_);
  status.add("missing_camera_info", missing_camera_info_);
  status.add("bad_camera_info", bad_camera_info_);
  status.add("tracker_refused", tracker_refused_);
  status.add("pairs_out_of_order", pairs_out_of_order_);
  status.add("pairs_skipped_rate", pairs_skipped_rate_);
  status.add("time_jump_resets", time_jump_resets_);
  status.add("pairs_dropped_waiting", pairs_dropped_waiting_);
  status.add("pairs_missing", pair_gaps_.missing());
  status.add("pairs_waiting", waiting_pairs_.size());
  status.add("twist_predictions", twist_used_);
  status.add("first_fit_predictions", first_fit_predictions_);
  status.add("pairs_without_features", pairs_without_features_);
  status.add("tracks_crowded", tracks_crowded_);
  status.add("features_last", last_stats_.published);
  status.add("track_ms_last", last_stats_.ms_total);
  status.add("decode_ms_last", decode_ms_last_);
  status.add("image_bits", image_scale_.bits());
  if (ros_options_.rectify) status.add("rectify_ms_last", rectifier_.rectifyMsLast());
  status.add("exposure_gain_last", last_stats_.exposure_gain_temporal);
  status.add("stereo_exposure_gain_last", last_stats_.exposure_gain_stereo);
  const StereoRigCheck& rig_check = rigCheck();
  status.add("stereo_row_offset_px", rig_check.medianRowOffsetPx());
  status.add("stereo_row_failed_fraction", rig_check.rowFailedFraction());
  status.add("stereo_negative_disparity_fraction", rig_check.negativeDisparityFraction());
  status.add("disparity_offset_px", rig_check.medianDisparityOffsetPx());
  status.add("disparity_offset_pairs", rig_check.disparityOffsetPairs());
  status.add("disparity_offset_corrected_px", last_stats_.disparity_offset_corrected_px);
  status.add("stereo_roll_deg", rig_check.medianStereoRollDeg());
  status.add("stereo_roll_edge_px", rig_check.medianRollEdgePx());
}

}  // namespace ekf_vislam
