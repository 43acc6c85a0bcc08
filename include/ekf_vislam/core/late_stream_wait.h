// The rule by which a message that waits for another stream (or for a transform) stops waiting.
// Shared by the measurement sequencer, the stereo tracker's pair queue and the tf waiting queue,
// so that every wait of the package ends the same way. No ROS.
#pragma once

#include <chrono>
#include <limits>

namespace ekf_vislam {

/// True once a wait has lasted more than `limit` s in message time (how far the stamps behind the
/// waiting message have moved on) and more than `limit` s in wall time (since it arrived).
/// Message time alone gives up on a stream that is only late: played at 10x on a loaded machine,
/// a moment of wall time is many seconds of message time, and what the wait was for would be
/// lost. Wall time alone would make the result depend on the machine's speed.
inline bool lateStreamWaitIsOver(double message_waited, double wall_waited, double limit) {
  return message_waited > limit && wall_waited > limit;
}

/// A caller without a wall clock (a recorded log read at once) passes these: every message then
/// counts as having waited forever in wall time, and message time decides alone.
constexpr double kArrivedLongAgo = -std::numeric_limits<double>::infinity();  ///< an arrival
constexpr double kNoWallClock = std::numeric_limits<double>::infinity();      ///< a "now"

/// The wall time of these waits: the steady clock, in s.
inline double steadyClockSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace ekf_vislam
