#include "ekf_vislam/tracker/twist_motion_prior.h"

#include "ekf_vislam/core/se3.h"

#include <algorithm>

namespace ekf_vislam {

namespace {
constexpr double kTwistHistory = 5.0;  // s of twists kept besides those since the last pair
}  // namespace

bool keepTwist(const StampedTwist& sample, double last_tracked_stamp,
               std::deque<StampedTwist>* twists) {
  if (!twists->empty() && sample.stamp <= twists->back().stamp) return false;
  twists->push_back(sample);
  double keep_from = sample.stamp - kTwistHistory;
  if (last_tracked_stamp > 0) keep_from = std::min(keep_from, last_tracked_stamp);
  while (twists->size() > 2 && (*twists)[1].stamp < keep_from) twists->pop_front();
  return true;
}

std::optional<CameraMotionPrior> motionPriorFromTwists(const std::deque<StampedTwist>& twists,
                                                       const Eigen::Matrix4d& cam_T_imu,
                                                       double from, double to) {
  if (twists.empty() || !(to > from)) return std::nullopt;
  Eigen::Matrix4d prev_T_cur = Eigen::Matrix4d::Identity();
  double t = from;
  // The first sample that drives part of the interval: the first one stamped after `from`.
  const auto first =
      std::upper_bound(twists.begin(), twists.end(), from,
                       [](double stamp, const StampedTwist& twist) { return stamp < twist.stamp; });
  for (auto twist = first; twist != twists.end(); ++twist) {
    const double end = std::min(twist->stamp, to);
    Vector6d xi;
    xi << twist->v, twist->w;
    prev_T_cur = prev_T_cur * se3::exp(xi * (end - t));
    t = end;
    if (t >= to) break;
  }
  if (t < to) return std::nullopt;  // the twists do not reach the image yet
  const Eigen::Matrix4d cam_prev_T_cam_cur = cam_T_imu * prev_T_cur * se3::inverse(cam_T_imu);
  const Eigen::Matrix4d cur_T_prev = se3::inverse(cam_prev_T_cam_cur);
  CameraMotionPrior prior;
  prior.cur_R_prev = cur_T_prev.block<3, 3>(0, 0);
  prior.cur_t_prev = cur_T_prev.block<3, 1>(0, 3);
  prior.has_translation = true;
  return prior;
}

}  // namespace ekf_vislam
