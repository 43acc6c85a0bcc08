// Inputs given in another frame than the body's: the fixed transforms from tf (cached; live tf or
// a bag's static transforms), and a queue that holds a stream's messages until tf knows their
// frame, so a /tf_static that comes a moment after the first messages loses nothing. Used by the
// twist combiner, the estimator node and the bag reader.
#pragma once

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/ros/conversions.h"

#include <ros/ros.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>

#include <Eigen/Geometry>

#include <cstdint>
#include <deque>
#include <map>
#include <string>

namespace ekf_vislam {

/// body_T_frame for fixed frames, from a tf buffer (tf2_ros::Buffer live, a BufferCore of a bag's
/// static transforms offline), cached once found.
class FixedFrameTransforms {
 public:
  FixedFrameTransforms() = default;
  FixedFrameTransforms(const tf2::BufferCore* buffer, std::string body_frame)
      : buffer_(buffer), body_frame_(std::move(body_frame)) {}
  const std::string& bodyFrame() const { return body_frame_; }
  /// Identity for the body frame itself (or an empty frame); false while tf has no transform
  /// (*why, when given: tf's reason).
  bool lookup(const std::string& frame, Eigen::Isometry3d* body_T_frame,
              std::string* why = nullptr) {
    if (frame.empty() || frame == body_frame_) {
      body_T_frame->setIdentity();
      return true;
    }
    const auto cached = cache_.find(frame);
    if (cached != cache_.end()) {
      *body_T_frame = cached->second;
      return true;
    }
    if (buffer_ == nullptr) {
      if (why != nullptr) *why = "no tf buffer";
      return false;
    }
    try {
      *body_T_frame = ros_conversions::toIsometry(
          buffer_->lookupTransform(body_frame_, frame, ros::Time(0)).transform);
    } catch (const tf2::TransformException& e) {
      if (why != nullptr) *why = e.what();
      return false;
    }
    cache_[frame] = *body_T_frame;
    return true;
  }

 private:
  const tf2::BufferCore* buffer_ = nullptr;  ///< not owned
  std::string body_frame_;
  std::map<std::string, Eigen::Isometry3d> cache_;
};

/// The messages of one input, in arrival order, until tf knows their frame. A message whose
/// frame tf lacks waits until its stream is `wait` s of message time past it and it has waited
/// `wait` s of wall time, then is dropped and counted. Message time alone is not enough: a bag
/// played fast on a loaded machine runs its messages ahead of a /tf_static whose connection is
/// still being set up, and those messages would be lost for being early; wall time alone would
/// drop more on a slow machine than on a fast one.
template <typename Msg>
class TfWaitingQueue {
 public:
  explicit TfWaitingQueue(const char* topic) : topic_(topic) {}
  const char* topic() const { return topic_; }
  /// `arrival`: wall time, s (steadyClockSeconds).
  void push(const typename Msg::ConstPtr& msg, double arrival = steadyClockSeconds()) {
    messages_.push_back({msg, arrival});
  }
  void clear() { messages_.clear(); }
  size_t size() const { return messages_.size(); }
  /// Messages dropped after waiting for their frame.
  uint64_t droppedWithoutTf() const { return dropped_; }

  /// use(msg, body_T_frame) for each waiting message in order while `transforms` knows
  /// frame_of(msg); a message that waited long enough (both clocks, at wall time `now`) is
  /// dropped: dropped(msg, frame).
  template <typename FrameOf, typename Use, typename Dropped>
  void drain(double wait, FixedFrameTransforms* transforms, const FrameOf& frame_of, const Use& use,
             const Dropped& dropped, double now = steadyClockSeconds()) {
    while (!messages_.empty()) {
      const Waiting& front = messages_.front();
      const Msg& msg = *front.msg;
      const std::string frame = frame_of(msg);
      Eigen::Isometry3d body_T_frame;
      if (!transforms->lookup(frame, &body_T_frame)) {
        const double message_wait = (messages_.back().msg->header.stamp - msg.header.stamp).toSec();
        if (!lateStreamWaitIsOver(message_wait, now - front.arrival, wait)) return;  // tf may come
        ++dropped_;
        dropped(msg, frame);
      } else {
        use(msg, body_T_frame);
      }
      messages_.pop_front();
    }
  }

 private:
  struct Waiting {
    typename Msg::ConstPtr msg;
    double arrival;  ///< wall time, s
  };
  const char* topic_;
  std::deque<Waiting> messages_;
  uint64_t dropped_ = 0;
};

}  // namespace ekf_vislam
