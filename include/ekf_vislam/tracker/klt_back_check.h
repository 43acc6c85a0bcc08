// The back-check of pyramidal KLT matches: a match is tracked back from where it moved to and
// kept when it lands within a tolerance of where it started. Only the listed candidates (the
// matches that passed the cheaper checks) are tracked back, so the second KLT costs only what
// can still be kept. OpenCV tracks every point on its own, so the result for a candidate is the
// one it would get in a call over all points. No ROS.
#pragma once

#include "ekf_vislam/tracker/pyramidal_klt.h"

#include <opencv2/core.hpp>

#include <vector>

namespace ekf_vislam {

/// The backward pass's settings: the forward pass's with at most `levels` pyramid levels above
/// the full image. The backward KLT starts where a consistent match returns to, so it needs none
/// of the reach the levels give; they only cost time and let the coarse images' wider context
/// pull a point away (tracker option klt/back_check_levels).
KltSettings backCheckSettings(const KltSettings& forward, int levels);

/// `origin[i]` lies in `origin_pyramid`'s image and moved to `moved[i]` in `moved_pyramid`'s.
/// Returns one flag per point: 1 where i is in `candidates`, its back-tracking from moved[i]
/// (started at origin[i], with the settings `klt`) converged and ended within `tolerance_px` of
/// origin[i].
std::vector<uint8_t> backCheck(const std::vector<cv::Mat>& moved_pyramid,
                               const std::vector<cv::Mat>& origin_pyramid,
                               const std::vector<cv::Point2f>& moved,
                               const std::vector<cv::Point2f>& origin,
                               const std::vector<size_t>& candidates, const KltSettings& klt,
                               double tolerance_px);

}  // namespace ekf_vislam
