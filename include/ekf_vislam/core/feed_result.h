// What one feed call of the estimator did. No ROS.
#pragma once

#include <string>

namespace ekf_vislam {

struct FeedResult {
  bool accepted = true;           ///< false: the whole message was rejected (see message)
  std::string message;            ///< one line when something was rejected or repaired
  int observations_updated = 0;   ///< used in the EKF update
  int observations_rejected = 0;  ///< dropped, for any reason (see stats for reasons)
  int landmarks_initialized = 0;
  int landmarks_marginalized = 0;
  int landmarks_shifted = 0;  ///< moved for a repeated frame (limits/repeated_frames: shift)
};

}  // namespace ekf_vislam
