// Which stereo pairs the tracker takes under input/max_rate_hz, decided by the pairs' stamps
// alone, so that the node (live, whatever its load) and track_stereo_images (offline) take the
// same pairs. A camera faster than the robot's computer can track (30 Hz 720p on two cores) is
// thinned to a steady rate instead of filling the node's backlog until pairs are dropped. No ROS.
#pragma once

#include <cstddef>
#include <vector>

namespace ekf_vislam {

/// A pair is due when it comes at least kRateSlack / max_rate_hz after the last tracked one. The
/// slack lets a camera's stamp jitter through: a 30 Hz camera whose stamps err by up to 3 ms
/// gives every pair under a 30 Hz limit, every second under 15 Hz, every third under 10 Hz. The
/// rate tracked is at most max_rate_hz / kRateSlack (a 20 Hz limit may pass all 30 Hz).
constexpr double kRateSlack = 0.75;

/// Whether the pair stamped `stamp` (s) is due for tracking after the last tracked pair's stamp
/// `last_tracked_stamp` (negative: none yet). Every pair is due when max_rate_hz <= 0.
bool dueForTracking(double stamp, double last_tracked_stamp, double max_rate_hz);

/// The indices of `stamps` (increasing, s) that dueForTracking takes in turn, the first always.
std::vector<size_t> framesDueForTracking(const std::vector<double>& stamps, double max_rate_hz);

}  // namespace ekf_vislam
