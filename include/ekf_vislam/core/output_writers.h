// Files the offline runner and the nodelet write: trajectory (TUM), map (CSV), statistics (JSON).
// No ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/types.h"

#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace ekf_vislam {

/// Per-frame processing times (ms) and summary figures for stats.json.
class ProcessingTimes {
 public:
  void add(double ms) { frame_ms_.push_back(ms); }
  size_t count() const { return frame_ms_.size(); }
  /// q in [0, 1], nearest-rank; 0 when empty.
  double percentile(double q) const;
  double max() const;
  double mean() const;

 private:
  std::vector<double> frame_ms_;
};

/// "t tx ty tz qx qy qz qw" per line, full precision.
void writeTumLine(std::ostream& out, const StampedPose& pose);
bool writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& trajectory,
                        std::string* error);

/// One line per pose: "t" then the 36 entries of its 6x6 covariance, row-major (ROS order x y z
/// rot-x rot-y rot-z, world axes, as VislamEstimator::poseCovarianceWorld). Both vectors have
/// the same length.
bool writeTrajectoryCovariance(const std::string& path, const std::vector<StampedPose>& trajectory,
                               const std::vector<Matrix6d>& covariances, std::string* error);

/// Header "id,x,y,z,sigma_x,sigma_y,sigma_z,observations", one row per confirmed landmark
/// (LandmarkEstimate::confirmed: the map; a landmark seen once is left out).
bool writeLandmarksCsv(const std::string& path, const std::vector<LandmarkEstimate>& landmarks,
                       std::string* error);

/// Everything stats.json holds besides the counters.
struct RunSummary {
  std::string mode;
  uint64_t frames = 0;
  uint64_t twists = 0;
  size_t landmarks_total = 0;   ///< every landmark initialized
  size_t landmarks_in_map = 0;  ///< of them, confirmed (landmarks.csv's rows)
  int peak_state_dimension = 0;
  size_t peak_active_landmarks = 0;
  double wall_s = 0.0;
  double data_s = 0.0;                  ///< time span of the input
  std::map<std::string, double> extra;  ///< more figures (e.g. "sequencer_late")
};

std::string statsToJson(const EstimatorStats& stats, const ProcessingTimes& times,
                        const RunSummary& summary);
bool writeStatsJson(const std::string& path, const EstimatorStats& stats,
                    const ProcessingTimes& times, const RunSummary& summary, std::string* error);

}  // namespace ekf_vislam
