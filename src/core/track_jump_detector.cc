#include "ekf_vislam/core/track_jump_detector.h"

#include "ekf_vislam/core/median.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

namespace {

constexpr int kIterations = 6;
constexpr double kHuberSigmas = 2.0;  // Huber corner of the robust fit, in robust sigmas
constexpr double kMinSigmaPx = 0.05;  // floor of the robust scale (noise-free input)

// 1.4826 x median absolute value: the standard deviation of Gaussian errors, robust to jumps.
double robustSigma(std::vector<double>* abs_errors) {
  return std::max(kMinSigmaPx, 1.4826 * upperMedian(abs_errors));
}

}  // namespace

TrackJumpResult detectTrackJumps(const std::vector<FlowCheck>& checks,
                                 const TrackJumpOptions& options) {
  TrackJumpResult result;
  result.jumped.assign(checks.size(), false);
  if (options.threshold_px <= 0.0 || static_cast<int>(checks.size()) < options.min_checks) {
    return result;
  }
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  Vector6d delta = Vector6d::Zero();
  std::vector<double> abs_errors(2 * checks.size());
  auto errorOf = [&](const FlowCheck& c) -> Eigen::Vector2d {
    return c.residual_change - c.H_pose * delta;
  };
  auto updateSigma = [&]() {
    for (size_t i = 0; i < checks.size(); ++i) {
      const Eigen::Vector2d e = errorOf(checks[i]);
      abs_errors[2 * i] = std::fabs(e(0));
      abs_errors[2 * i + 1] = std::fabs(e(1));
    }
    result.sigma_px = robustSigma(&abs_errors);
  };
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    updateSigma();
    Matrix6d normal = Matrix6d::Zero();
    Vector6d rhs = Vector6d::Zero();
    for (const FlowCheck& c : checks) {
      const Eigen::Vector2d e = errorOf(c);
      for (int j = 0; j < 2; ++j) {
        const double scale = std::sqrt(result.sigma_px * result.sigma_px + c.landmark_variance(j));
        // Huber: weight 1 / scale^2 inside the corner, decaying as 1 / |e| beyond it.
        const double w =
            1.0 / (scale * scale * std::max(1.0, std::fabs(e(j)) / (kHuberSigmas * scale)));
        normal.noalias() += w * c.H_pose.row(j).transpose() * c.H_pose.row(j);
        rhs.noalias() += w * c.H_pose.row(j).transpose() * c.residual_change(j);
      }
    }
    // A small ridge keeps directions the landmarks do not observe (e.g. translation with only
    // distant points) at zero instead of letting them absorb noise.
    normal.diagonal().array() += 1e-9 * normal.trace() + 1e-12;
    const Vector6d next = normal.ldlt().solve(rhs);
    if (!next.allFinite()) return result;
    delta = next;
  }
  updateSigma();
  result.common_pose_error = delta;
  result.tested = true;
  size_t flagged = 0;
  for (size_t i = 0; i < checks.size(); ++i) {
    const Eigen::Vector2d e = errorOf(checks[i]);
    for (int j = 0; j < 2; ++j) {
      const double sigma =
          std::sqrt(result.sigma_px * result.sigma_px + checks[i].landmark_variance(j));
      const double threshold = std::max(options.threshold_px, options.threshold_sigmas * sigma);
      if (std::fabs(e(j)) > threshold) result.jumped[i] = true;
    }
    if (result.jumped[i]) ++flagged;
  }
  if (static_cast<double>(flagged) >
      options.max_jump_fraction * static_cast<double>(checks.size())) {
    result.jumped.assign(checks.size(), false);
    result.tested = false;
  }
  return result;
}

}  // namespace ekf_vislam
