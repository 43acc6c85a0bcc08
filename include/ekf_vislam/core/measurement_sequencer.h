// Puts twists, feature frames and accelerometer samples into stamp order before they reach the
// estimator, so the live nodelet and the offline runner feed the core the same sequence. No ROS.
#pragma once

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/core/types.h"

#include <cstddef>
#include <deque>
#include <optional>
#include <variant>
#include <vector>

namespace ekf_vislam {

using Measurement = std::variant<TwistData, FeatureFrame, AccelerometerData>;

/// Which stream a measurement belongs to: the alternatives of Measurement, in their order.
enum class MeasurementKind { kTwist = 0, kFrame = 1, kAccelerometer = 2 };
inline MeasurementKind kindOf(const Measurement& m) {
  return static_cast<MeasurementKind>(m.index());
}
/// "twist", "feature frame", "accelerometer sample" (log messages).
const char* kindName(MeasurementKind kind);

inline double stampOf(const Measurement& m) {
  return std::visit([](const auto& data) { return data.stamp; }, m);
}

/// A message is released once every stream has delivered a stamp >= its own (no later message
/// can precede it; the accelerometer counts once it has delivered one sample: a robot without
/// one waits for nothing), or once it has waited more than max_delay both in message time (the
/// newest stamp seen is that far past it) and in wall time (since its arrival): a stream
/// stopped (lateStreamWaitIsOver), or when the buffer is over max_buffered. At equal stamps the
/// accelerometer sample goes first, then the twist, then the frame.
/// Wall time is the caller's clock, in s: push() takes a message's arrival, popReady() the time
/// now. Without them (kArrivedLongAgo, kNoWallClock) message time decides alone, which is what a
/// reader of a recorded log wants: its messages arrive at once, and at real time a live run's
/// wall time passes with its message time.
/// A message older than what was already released is returned anyway (the estimator rejects or
/// absorbs it and counts it) and counted in late().
class MeasurementSequencer {
 public:
  struct Options {
    double max_delay = 0.3;      ///< s
    size_t max_buffered = 1000;  ///< messages
  };
  MeasurementSequencer() = default;
  explicit MeasurementSequencer(const Options& options) : options_(options) {}

  void push(Measurement measurement, double arrival = kArrivedLongAgo);
  /// Messages ready for the estimator at wall time `now`, in order.
  std::vector<Measurement> popReady(double now = kNoWallClock);
  /// Everything still buffered, in order (end of input).
  std::vector<Measurement> flush();
  void clear();

  size_t buffered() const { return buffer_.size(); }
  /// The twists still buffered, in stamp order.
  std::vector<TwistData> bufferedTwists() const;
  size_t late() const { return late_; }

 private:
  struct Buffered {
    Measurement measurement;
    double arrival;  ///< wall time, s
  };
  Options options_;
  std::deque<Buffered> buffer_;  ///< sorted by (stamp, then accelerometer, twist, frame)
  double newest_twist_ = -1e300;
  double newest_frame_ = -1e300;
  std::optional<double> newest_accel_;  ///< none until the first accelerometer sample
  double released_until_ = -1e300;
  size_t late_ = 0;
};

}  // namespace ekf_vislam
