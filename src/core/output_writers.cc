#include "ekf_vislam/core/output_writers.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <numeric>
#include <sstream>

namespace ekf_vislam {

double ProcessingTimes::percentile(double q) const {
  if (frame_ms_.empty()) return 0.0;
  std::vector<double> sorted = frame_ms_;
  std::sort(sorted.begin(), sorted.end());
  const size_t rank = static_cast<size_t>(std::ceil(std::clamp(q, 0.0, 1.0) * sorted.size()));
  return sorted[std::min(sorted.size() - 1, rank == 0 ? 0 : rank - 1)];
}

double ProcessingTimes::max() const {
  return frame_ms_.empty() ? 0.0 : *std::max_element(frame_ms_.begin(), frame_ms_.end());
}

double ProcessingTimes::mean() const {
  return frame_ms_.empty()
             ? 0.0
             : std::accumulate(frame_ms_.begin(), frame_ms_.end(), 0.0) / frame_ms_.size();
}

void writeTumLine(std::ostream& out, const StampedPose& pose) {
  const Eigen::Quaterniond q(pose.world_T_imu.linear());
  const Eigen::Vector3d p = pose.world_T_imu.translation();
  out << std::fixed << std::setprecision(9) << pose.stamp << ' ' << p.x() << ' ' << p.y() << ' '
      << p.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
}

namespace {
bool openForWriting(const std::string& path, std::ofstream* out, std::string* error) {
  out->open(path);
  if (!*out && error != nullptr) *error = path + ": cannot open for writing";
  return static_cast<bool>(*out);
}
bool finish(const std::string& path, std::ofstream* out, std::string* error) {
  out->close();
  if (!*out && error != nullptr) *error = path + ": write failed";
  return static_cast<bool>(*out);
}
}  // namespace

bool writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& trajectory,
                        std::string* error) {
  std::ofstream out;
  if (!openForWriting(path, &out, error)) return false;
  for (const StampedPose& pose : trajectory) writeTumLine(out, pose);
  return finish(path, &out, error);
}

bool writeTrajectoryCovariance(const std::string& path, const std::vector<StampedPose>& trajectory,
                               const std::vector<Matrix6d>& covariances, std::string* error) {
  if (trajectory.size() != covariances.size()) {
    if (error) *error = path + ": one covariance per pose is needed";
    return false;
  }
  std::ofstream out;
  if (!openForWriting(path, &out, error)) return false;
  out << std::setprecision(17);
  for (size_t i = 0; i < trajectory.size(); ++i) {
    out << trajectory[i].stamp;
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) out << ' ' << covariances[i](r, c);
    }
    out << '\n';
  }
  return finish(path, &out, error);
}

bool writeLandmarksCsv(const std::string& path, const std::vector<LandmarkEstimate>& landmarks,
                       std::string* error) {
  std::ofstream out;
  if (!openForWriting(path, &out, error)) return false;
  out << "id,x,y,z,sigma_x,sigma_y,sigma_z,observations\n" << std::setprecision(9);
  for (const LandmarkEstimate& l : landmarks) {
    if (!l.confirmed()) continue;
    const Eigen::Vector3d sigma = l.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    out << l.id << ',' << l.p_world.x() << ',' << l.p_world.y() << ',' << l.p_world.z() << ','
        << sigma.x() << ',' << sigma.y() << ',' << sigma.z() << ',' << l.observations << '\n';
  }
  return finish(path, &out, error);
}

std::string statsToJson(const EstimatorStats& stats, const ProcessingTimes& times,
                        const RunSummary& summary) {
  std::ostringstream j;
  j << std::setprecision(6);
  auto number = [](double v) {
    std::ostringstream s;
    if (std::isfinite(v)) {
      s << std::setprecision(9) << v;
    } else {
      s << "null";
    }
    return s.str();
  };
  j << "{\n";
  j << "  \"mode\": \"" << summary.mode << "\",\n";
  j << "  \"frames\": " << summary.frames << ",\n";
  j << "  \"twists\": " << summary.twists << ",\n";
  j << "  \"landmarks\": " << summary.landmarks_total << ",\n";
  j << "  \"landmarks_in_map\": " << summary.landmarks_in_map << ",\n";
  j << "  \"observations_used\": "
    << stats.get(Counter::kObservationUpdate) + stats.get(Counter::kObservationInitialized)
    << ",\n";
  j << "  \"observations_rejected\": " << stats.observationsRejected() << ",\n";
  j << "  \"peak_state_dimension\": " << summary.peak_state_dimension << ",\n";
  j << "  \"peak_active_landmarks\": " << summary.peak_active_landmarks << ",\n";
  j << "  \"data_s\": " << number(summary.data_s) << ",\n";
  j << "  \"wall_s\": " << number(summary.wall_s) << ",\n";
  j << "  \"realtime_factor\": "
    << number(summary.wall_s > 0.0 ? summary.data_s / summary.wall_s : 0.0) << ",\n";
  j << "  \"frame_ms\": {\"mean\": " << number(times.mean())
    << ", \"p50\": " << number(times.percentile(0.5))
    << ", \"p95\": " << number(times.percentile(0.95))
    << ", \"p99\": " << number(times.percentile(0.99)) << ", \"max\": " << number(times.max())
    << "},\n";
  j << "  \"counters\": {";
  for (int i = 0; i < static_cast<int>(Counter::kCount); ++i) {
    const Counter c = static_cast<Counter>(i);
    j << (i == 0 ? "\n" : ",\n") << "    \"" << counterName(c) << "\": " << stats.get(c);
  }
  j << "\n  }";
  for (const auto& [key, value] : summary.extra) j << ",\n  \"" << key << "\": " << number(value);
  j << "\n}\n";
  return j.str();
}

bool writeStatsJson(const std::string& path, const EstimatorStats& stats,
                    const ProcessingTimes& times, const RunSummary& summary, std::string* error) {
  std::ofstream out;
  if (!openForWriting(path, &out, error)) return false;
  out << statsToJson(stats, times, summary);
  return finish(path, &out, error);
}

}  // namespace ekf_vislam
