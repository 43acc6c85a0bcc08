#include "ekf_vislam/tracker/disparity_offset_fit.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/tracker/pnp_ransac.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <Eigen/Cholesky>

#include <cmath>

namespace ekf_vislam {

namespace {

constexpr int kMaxRounds = 6;            // choose, then fit, at most this often
constexpr int kGaussNewtonSteps = 3;     // per round
constexpr int kMinInliers = 30;          // fewer: no fit
constexpr double kMinDisparityPx = 0.5;  // a corrected disparity below this has no depth to use

using Vector7d = Eigen::Matrix<double, 7, 1>;
using Matrix7d = Eigen::Matrix<double, 7, 7>;

struct Parameters {
  Eigen::Matrix3d cur_R_prev;
  Eigen::Vector3d cur_t_prev;
  double correction_px = 0;  // true minus measured disparity: minus the reported offset
};

// A match's residual (projection minus current pixel) and its Jacobian in (dtheta, dt,
// dcorrection), the motion perturbed as in pnp_ransac.h; false when the corrected disparity or
// the moved point's depth is not positive enough to project.
bool residualOf(const Parameters& x, const DisparityOffsetMatch& match, const StereoCalibration& c,
                Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 7>* jacobian) {
  const double disparity = match.prev_disparity + x.correction_px;
  if (!(disparity > kMinDisparityPx)) return false;
  const std::optional<Eigen::Vector3d> p_prev = triangulate(c, match.prev_left, disparity);
  if (!p_prev) return false;
  const Eigen::Vector3d q = x.cur_R_prev * *p_prev + x.cur_t_prev;
  if (q.z() <= 0) return false;
  *residual = project(c, q) - Eigen::Vector2d(match.cur_left.x, match.cur_left.y);
  if (jacobian) {
    const Eigen::Matrix<double, 2, 6> d_motion = reprojectionJacobian(c, q);
    // p_prev scales as 1 / disparity: d p_prev / d correction = -p_prev / disparity.
    jacobian->leftCols<6>() = d_motion;
    jacobian->col(6) = d_motion.rightCols<3>() * (x.cur_R_prev * (-*p_prev / disparity));
  }
  return true;
}

std::vector<int> chooseMatches(const Parameters& x, const std::vector<DisparityOffsetMatch>& all,
                               const StereoCalibration& c, double threshold_px) {
  std::vector<int> chosen;
  Eigen::Vector2d residual;
  for (int i = 0; i < static_cast<int>(all.size()); ++i) {
    if (residualOf(x, all[i], c, &residual, nullptr) &&
        residual.squaredNorm() <= threshold_px * threshold_px) {
      chosen.push_back(i);
    }
  }
  return chosen;
}

// The normal matrix and gradient of the chosen matches' squared residuals; their sum in *cost.
void normalEquations(const Parameters& x, const std::vector<DisparityOffsetMatch>& all,
                     const std::vector<int>& chosen, const StereoCalibration& c, Matrix7d* normal,
                     Vector7d* gradient, double* cost) {
  normal->setZero();
  gradient->setZero();
  *cost = 0;
  Eigen::Vector2d residual;
  Eigen::Matrix<double, 2, 7> jacobian;
  for (const int i : chosen) {
    if (!residualOf(x, all[i], c, &residual, &jacobian)) continue;
    normal->noalias() += jacobian.transpose() * jacobian;
    gradient->noalias() += jacobian.transpose() * residual;
    *cost += residual.squaredNorm();
  }
}

void gaussNewton(const std::vector<DisparityOffsetMatch>& all, const std::vector<int>& chosen,
                 const StereoCalibration& c, Parameters* x) {
  Matrix7d normal;
  Vector7d gradient;
  double cost;
  for (int step = 0; step < kGaussNewtonSteps; ++step) {
    normalEquations(*x, all, chosen, c, &normal, &gradient, &cost);
    const Vector7d delta = -normal.ldlt().solve(gradient);
    if (!delta.allFinite()) return;
    const Eigen::Matrix3d turn = se3::expSO3(delta.head<3>());
    x->cur_R_prev = turn * x->cur_R_prev;
    x->cur_t_prev = turn * x->cur_t_prev + delta.segment<3>(3);
    x->correction_px += delta(6);
  }
}

}  // namespace

DisparityOffsetFit fitDisparityOffset(const std::vector<DisparityOffsetMatch>& matches,
                                      const Eigen::Matrix3d& cur_R_prev,
                                      const Eigen::Vector3d& cur_t_prev,
                                      const StereoCalibration& calibration, double threshold_px) {
  DisparityOffsetFit result;
  Parameters x{cur_R_prev, cur_t_prev, 0.0};
  std::vector<int> chosen;
  // After the last round the set is chosen once more, for the fitted motion and offset: the
  // round that finds it unchanged has chosen it already.
  for (int round = 0; round <= kMaxRounds; ++round) {
    std::vector<int> next = chooseMatches(x, matches, calibration, threshold_px);
    if (static_cast<int>(next.size()) < kMinInliers) return result;
    const bool unchanged = next == chosen;
    chosen = std::move(next);
    if (unchanged || round == kMaxRounds) break;
    gaussNewton(matches, chosen, calibration, &x);
  }
  const int n = static_cast<int>(chosen.size());
  Matrix7d normal;
  Vector7d gradient;
  double cost;
  normalEquations(x, matches, chosen, calibration, &normal, &gradient, &cost);
  // The pixel noise from the chosen matches' residuals (two per match, seven parameters).
  const double pixel_variance = cost / std::max(1, 2 * n - 7);
  const Eigen::LDLT<Matrix7d> ldlt(normal);
  const Vector7d last = ldlt.solve(Vector7d::Unit(6));
  result.fitted = true;
  result.offset_px = -x.correction_px;
  result.offset_sigma_px = last.allFinite() && last(6) > 0
                               ? std::sqrt(pixel_variance * last(6))
                               : std::numeric_limits<double>::infinity();
  result.inliers = n;
  result.cur_R_prev = x.cur_R_prev;
  result.cur_t_prev = x.cur_t_prev;
  return result;
}

}  // namespace ekf_vislam
