#include "ekf_vislam/core/standstill_detector.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace ekf_vislam {

namespace {
/// At rest while this fraction of the shared tracks moved at most the bound: a fifth of them may
/// be outliers or tracks that slid, while a moving camera moves more than a fifth (the near and
/// the peripheral ones) even where the far ones near the direction of travel barely move.
constexpr double kQuantile = 0.8;

bool finite(const StereoObservation& f) {
  return std::isfinite(f.u_left) && std::isfinite(f.v_left);
}
}  // namespace

double StandstillDetector::displacementQuantile(const FeatureFrame& frame) const {
  std::vector<double> displacements;
  displacements.reserve(frame.features.size());
  for (const StereoObservation& f : frame.features) {
    const auto it = reference_.find(f.id);
    if (it == reference_.end() || !finite(f)) continue;
    displacements.push_back((Eigen::Vector2d(f.u_left, f.v_left) - it->second).norm());
  }
  if (displacements.empty() || static_cast<int>(displacements.size()) < options_->min_tracks) {
    return -1.0;
  }
  const auto at = displacements.begin() +
                  static_cast<std::ptrdiff_t>(kQuantile * (displacements.size() - 1) + 0.5);
  std::nth_element(displacements.begin(), at, displacements.end());
  return *at;
}

bool StandstillDetector::observe(const FeatureFrame& frame) {
  if (!options_->enabled) {
    reset();
    return false;
  }
  const double moved = displacementQuantile(frame);
  at_rest_ = moved >= 0.0 && moved <= options_->max_displacement_px;
  // At rest the reference keeps its positions, and tracks that start during the rest join it
  // where they start; tracks gone from this frame leave it (ids are not reused), so a long stop
  // holds no more than a frame's tracks. Moving, this frame becomes the reference.
  std::unordered_map<uint32_t, Eigen::Vector2d> next;
  next.reserve(frame.features.size());
  for (const StereoObservation& f : frame.features) {
    if (!finite(f)) continue;
    const auto it = reference_.find(f.id);
    next.emplace(f.id, at_rest_ && it != reference_.end() ? it->second
                                                          : Eigen::Vector2d(f.u_left, f.v_left));
  }
  reference_.swap(next);
  return at_rest_;
}

void StandstillDetector::reset() {
  reference_.clear();
  at_rest_ = false;
}

}  // namespace ekf_vislam
