// Tracks whose landmark keeps restarting: points that move (a car ahead), not landmarks. No ROS.
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>

namespace ekf_vislam {

/// Counts, per track id, how often its landmark restarted (gated grossly, or the track-jump test
/// twice in a row). A static point's track slides onto another point now and then; a point that
/// moves with the camera (a car driving ahead) disagrees with every prediction of a static point,
/// so its landmark restarts again and again, and each new landmark, still uncertain along its
/// line of sight, takes a few updates that pull the pose towards "not moving" before the gate
/// rejects it. Once an id has restarted more than `max_restarts` times its track is dropped: its
/// observations are not used until the track ends (absent from more than max_track_gap non-empty
/// frames), and an id seen after that is a new track. max_restarts 0: no limit.
class RestartLimiter {
 public:
  RestartLimiter(const int& max_restarts, const int& max_track_gap)
      : max_restarts_(&max_restarts), max_track_gap_(&max_track_gap) {}

  /// The landmark of `id` restarted (or its track jumped). True when that was one restart too
  /// many: the track is dropped from now on.
  bool recordRestart(uint32_t id);
  /// True for an id whose track has been dropped and has not ended.
  bool dropped(uint32_t id) const { return dropped_.count(id) > 0; }
  /// After each frame's candidates: the ids present keep their counts; an id absent from more
  /// than max_track_gap non-empty frames in a row is forgotten (its track ended). An empty
  /// message ends no track.
  void endFrame(const std::unordered_set<uint32_t>& present, bool frame_empty);
  void reset();
  size_t droppedTracks() const { return dropped_.size(); }

 private:
  struct Entry {
    int restarts = 0;
    int frames_absent = 0;
  };
  const int* max_restarts_;
  const int* max_track_gap_;
  std::unordered_map<uint32_t, Entry> entries_;  ///< ids restarted at least once
  std::unordered_set<uint32_t> dropped_;
};

}  // namespace ekf_vislam
