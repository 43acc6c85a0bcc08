// Chi-square distribution: CDF and quantile, computed (no table). No ROS.
#pragma once

namespace ekf_vislam {

/// P(X <= x) for X ~ chi-square with `dof` degrees of freedom (regularized lower gamma).
double chiSquareCdf(double x, int dof);
/// x such that chiSquareCdf(x, dof) = probability, probability in (0, 1).
double chiSquareQuantile(double probability, int dof);

}  // namespace ekf_vislam
