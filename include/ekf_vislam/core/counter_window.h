// Windows over cumulative counters (EstimatorStats): what each counter added since the last
// window closed, once the first of them has grown enough. The node's hints read their figures
// this way. No ROS.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

namespace ekf_vislam {

template <size_t N>
class CounterWindow {
 public:
  using Counts = std::array<uint64_t, N>;

  /// When `now[0]` has grown by at least `min_first` since the window started: closes it,
  /// returns each counter's increase over it and starts the next at `now`. Else nullopt.
  std::optional<Counts> close(const Counts& now, uint64_t min_first) {
    if (now[0] - start_[0] < min_first) return std::nullopt;
    Counts increase;
    for (size_t i = 0; i < N; ++i) increase[i] = now[i] - start_[i];
    start_ = now;
    return increase;
  }

 private:
  Counts start_{};
};

}  // namespace ekf_vislam
