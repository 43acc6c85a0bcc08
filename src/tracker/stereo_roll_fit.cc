#include "ekf_vislam/tracker/stereo_roll_fit.h"

#include "ekf_vislam/core/median.h"

#include <Eigen/Dense>

#include <cmath>

namespace ekf_vislam {

namespace {

constexpr int kMaxRounds = 6;

// Row offset = c0 + c1 x + c2 y, x and y the left pixel's distance from the principal point.
using Line = Eigen::Vector3d;

double predicted(const Line& line, double x, double y) {
  return line(0) + line(1) * x + line(2) * y;
}

}  // namespace

StereoRollFit fitStereoRoll(const std::vector<cv::Point2f>& left,
                            const std::vector<float>& row_offsets,
                            const cv::Point2f& principal_point, double window_px) {
  StereoRollFit fit;
  const size_t n = std::min(left.size(), row_offsets.size());
  if (n < static_cast<size_t>(kStereoRollMinMatches)) return fit;
  std::vector<float> offsets(row_offsets.begin(), row_offsets.begin() + n);
  Line line(upperMedian(&offsets), 0.0, 0.0);
  std::vector<uint8_t> chosen(n, 0);
  for (int round = 0; round < kMaxRounds; ++round) {
    bool changed = false;
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    int count = 0;
    for (size_t i = 0; i < n; ++i) {
      const double x = left[i].x - principal_point.x;
      const double y = left[i].y - principal_point.y;
      const uint8_t in = std::abs(row_offsets[i] - predicted(line, x, y)) <= window_px;
      changed |= in != chosen[i];
      chosen[i] = in;
      if (!in) continue;
      const Eigen::Vector3d a(1.0, x, y);
      normal += a * a.transpose();
      rhs += a * row_offsets[i];
      ++count;
    }
    if (!changed && fit.fitted) break;
    fit = StereoRollFit();
    if (count < kStereoRollMinMatches) return fit;
    // The columns' spread: the roll is their slope.
    const double mean_x = normal(0, 1) / count;
    if (normal(1, 1) / count - mean_x * mean_x <
        kStereoRollMinColumnSpreadPx * kStereoRollMinColumnSpreadPx) {
      return fit;
    }
    const Eigen::LDLT<Eigen::Matrix3d> solver(normal);
    if (solver.info() != Eigen::Success) return fit;
    line = solver.solve(rhs);
    double squares = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!chosen[i]) continue;
      const double r = row_offsets[i] - predicted(line, left[i].x - principal_point.x,
                                                  left[i].y - principal_point.y);
      squares += r * r;
    }
    const double variance = count > 3 ? squares / (count - 3) : 0.0;
    fit.fitted = std::isfinite(line(1));
    fit.roll_rad = line(1);
    fit.roll_sigma_rad = std::sqrt(variance * solver.solve(Eigen::Vector3d::UnitY())(1));
    fit.row_offset_px = line(0);
    fit.inliers = count;
  }
  return fit;
}

}  // namespace ekf_vislam
