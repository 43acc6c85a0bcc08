#include "ekf_vislam/ros/feature_message.h"

namespace ekf_vislam {

ekf_vislam::StereoFeatureArray featureMessage(const std_msgs::Header& left_header,
                                              const std::string& fallback_frame,
                                              const StereoFrame& frame) {
  ekf_vislam::StereoFeatureArray msg;
  msg.header = left_header;
  if (msg.header.frame_id.empty()) msg.header.frame_id = fallback_frame;
  msg.features.resize(frame.features.size());
  for (size_t i = 0; i < frame.features.size(); ++i) {
    const TrackedFeature& f = frame.features[i];
    ekf_vislam::StereoFeature& out = msg.features[i];
    out.id = f.id;
    out.u_left = f.left.x;
    out.v_left = f.left.y;
    out.u_right = f.right.x;
    out.v_right = f.right.y;
  }
  return msg;
}

}  // namespace ekf_vislam
