#pragma once

#include <vector>

namespace ekf_vislam {

/// Recognizes time going back on the inputs: a bag played again (`rosbag play -l`, or a second
/// `rosbag play` of the same recording) or a clock stepped back. A message stamped more than
/// `threshold` s before the newest message of its own stream has jumped back. The test is per
/// stream because streams may lag one another by any amount (a busy tracker's features come
/// late against the twist), while one stream keeps its order.
///
/// After a jump every stream starts afresh, so the other streams' first messages of the new time
/// are accepted without a second jump. A message that was still in flight from before the jump
/// on another stream is accepted too (it is newer); that stream's next message of the new time
/// then jumps back in its turn, and the caller starts once more.
class TimeJumpDetector {
 public:
  /// `threshold` s (0: never a jump) over `streams` streams numbered from 0.
  TimeJumpDetector(double threshold, int streams);

  /// True when `stamp` (s) on `stream` lies more than the threshold before that stream's newest
  /// stamp; then every stream is cleared and `stamp` becomes the newest of its own.
  bool jumpedBack(int stream, double stamp);

  /// How far the last jump went back, s (0 before any jump).
  double lastJump() const { return last_jump_; }

  /// Forgets every stream's newest stamp.
  void reset();

 private:
  double threshold_;
  std::vector<double> newest_;  ///< per stream; -inf before its first stamp
  double last_jump_ = 0.0;
};

}  // namespace ekf_vislam
