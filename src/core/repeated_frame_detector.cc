#include "ekf_vislam/core/repeated_frame_detector.h"

namespace ekf_vislam {

bool RepeatedFrameDetector::isRepeat(const FeatureFrame& frame, std::vector<size_t>* new_tracks) {
  if (new_tracks != nullptr) new_tracks->clear();
  int shared = 0, identical = 0;
  std::unordered_map<uint32_t, Eigen::Vector4d> current;
  current.reserve(frame.features.size());
  for (size_t i = 0; i < frame.features.size(); ++i) {
    const StereoObservation& f = frame.features[i];
    const Eigen::Vector4d z(f.u_left, f.v_left, f.u_right, f.v_right);
    current.emplace(f.id, z);
    auto it = previous_.find(f.id);
    if (it == previous_.end()) {
      if (new_tracks != nullptr) new_tracks->push_back(i);
      continue;
    }
    ++shared;
    // Bit-identical (NaN never is): a fresh measurement of a real tracker differs at least in
    // its sub-pixel digits.
    if ((it->second.array() == z.array()).all()) ++identical;
  }
  previous_.swap(current);
  // Most, not all: a few corrupted features (gross outliers, NaN) must not hide a re-sent frame.
  return shared >= min_shared_ && 2 * identical > shared;
}

}  // namespace ekf_vislam
