// Recognizes messages missing from a periodic stream by its stamps: a camera that dropped frames,
// or a subscriber queue that overflowed because its node fell behind (ROS drops the oldest message
// of a full queue without telling the callback). No ROS.
#pragma once

#include <cstdint>
#include <deque>
#include <string>

namespace ekf_vislam {

class StampGapDetector {
 public:
  /// A gap is an interval longer than `factor` times the stream's period, the median of its last
  /// `window` intervals (estimated once `min_intervals` have been seen).
  explicit StampGapDetector(double factor = 1.5, int window = 21, int min_intervals = 5)
      : factor_(factor), window_(window), min_intervals_(min_intervals) {}

  /// The next stamp of the stream (s): how many messages are missing before it (0: none, or the
  /// period is not known yet). A stamp that does not move forward starts the estimate afresh.
  int add(double stamp);
  /// The period the gaps are measured against (0 while unknown).
  double period() const;
  /// Every message add() has counted missing so far (reset() keeps it).
  uint64_t missing() const { return missing_; }
  /// The warning's common part after add(stamp) returned `missing` > 0: "about N <what>(s)
  /// missing before <stamp> (period P s; M so far)".
  std::string describeMissing(int missing, double stamp, const char* what) const;
  /// Forgets the stream's period and last stamp (time went back, the node was reset).
  void reset();

 private:
  double factor_;
  int window_;
  int min_intervals_;
  bool has_last_ = false;
  double last_ = 0.0;
  std::deque<double> intervals_;
  uint64_t missing_ = 0;
};

}  // namespace ekf_vislam
