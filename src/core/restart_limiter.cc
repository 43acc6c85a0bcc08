#include "ekf_vislam/core/restart_limiter.h"

namespace ekf_vislam {

bool RestartLimiter::recordRestart(uint32_t id) {
  Entry& entry = entries_[id];
  ++entry.restarts;
  entry.frames_absent = 0;
  if (*max_restarts_ <= 0 || entry.restarts <= *max_restarts_) return false;
  return dropped_.insert(id).second;
}

void RestartLimiter::endFrame(const std::unordered_set<uint32_t>& present, bool frame_empty) {
  if (frame_empty) return;
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (present.count(it->first)) {
      it->second.frames_absent = 0;
    } else if (++it->second.frames_absent > *max_track_gap_) {
      dropped_.erase(it->first);
      it = entries_.erase(it);
      continue;
    }
    ++it;
  }
}

void RestartLimiter::reset() {
  entries_.clear();
  dropped_.clear();
}

}  // namespace ekf_vislam
