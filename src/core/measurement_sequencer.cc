#include "ekf_vislam/core/measurement_sequencer.h"

#include "ekf_vislam/core/late_stream_wait.h"

#include <algorithm>

namespace ekf_vislam {
namespace {

// At equal stamps: accelerometer sample (its period ends there), twist, frame.
int rank(const Measurement& m) {
  switch (kindOf(m)) {
    case MeasurementKind::kAccelerometer: return 0;
    case MeasurementKind::kTwist: return 1;
    case MeasurementKind::kFrame: break;
  }
  return 2;
}

// Strict order: by stamp, then rank.
bool before(const Measurement& a, const Measurement& b) {
  const double ta = stampOf(a), tb = stampOf(b);
  if (ta != tb) return ta < tb;
  return rank(a) < rank(b);
}

}  // namespace

const char* kindName(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::kFrame: return "feature frame";
    case MeasurementKind::kAccelerometer: return "accelerometer sample";
    case MeasurementKind::kTwist: break;
  }
  return "twist";
}

void MeasurementSequencer::push(Measurement measurement, double arrival) {
  const double stamp = stampOf(measurement);
  if (stamp < released_until_) ++late_;
  switch (kindOf(measurement)) {
    case MeasurementKind::kTwist: newest_twist_ = std::max(newest_twist_, stamp); break;
    case MeasurementKind::kFrame: newest_frame_ = std::max(newest_frame_, stamp); break;
    case MeasurementKind::kAccelerometer:
      newest_accel_ = std::max(newest_accel_.value_or(stamp), stamp);
      break;
  }
  // Insert after every element that is not after it (stable for equal keys).
  auto it = std::upper_bound(
      buffer_.begin(), buffer_.end(), measurement,
      [](const Measurement& m, const Buffered& b) { return before(m, b.measurement); });
  buffer_.insert(it, Buffered{std::move(measurement), arrival});
}

std::vector<Measurement> MeasurementSequencer::popReady(double now) {
  std::vector<Measurement> ready;
  // A stream that never delivered (the accelerometer) holds nothing back.
  const double all_seen = std::min({newest_twist_, newest_frame_, newest_accel_.value_or(1e300)});
  const double newest = std::max({newest_twist_, newest_frame_, newest_accel_.value_or(-1e300)});
  while (!buffer_.empty()) {
    const double stamp = stampOf(buffer_.front().measurement);
    // Every stream has reached this stamp: nothing earlier can still arrive (each stream is
    // in order), and the equal-stamp tie is already resolved by the buffer order.
    const bool covered = stamp <= all_seen;
    const bool timed_out =
        lateStreamWaitIsOver(newest - stamp, now - buffer_.front().arrival, options_.max_delay);
    const bool overfull = buffer_.size() > options_.max_buffered;
    if (!(covered || timed_out || overfull)) break;
    released_until_ = std::max(released_until_, stamp);
    ready.push_back(std::move(buffer_.front().measurement));
    buffer_.pop_front();
  }
  return ready;
}

std::vector<Measurement> MeasurementSequencer::flush() {
  std::vector<Measurement> all;
  all.reserve(buffer_.size());
  for (Buffered& b : buffer_) all.push_back(std::move(b.measurement));
  buffer_.clear();
  if (!all.empty()) released_until_ = std::max(released_until_, stampOf(all.back()));
  return all;
}

std::vector<TwistData> MeasurementSequencer::bufferedTwists() const {
  std::vector<TwistData> twists;
  for (const Buffered& b : buffer_) {
    if (const TwistData* twist = std::get_if<TwistData>(&b.measurement)) twists.push_back(*twist);
  }
  return twists;
}

void MeasurementSequencer::clear() {
  buffer_.clear();
  newest_twist_ = newest_frame_ = released_until_ = -1e300;
  newest_accel_.reset();
}

}  // namespace ekf_vislam
