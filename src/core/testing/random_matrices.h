// Seeded random matrices for the core's unit tests. Header-only.
#pragma once

#include <Eigen/Core>

#include <random>

namespace ekf_vislam {
namespace testing {

/// Entries uniform in [-1, 1].
inline Eigen::MatrixXd randomMatrix(int rows, int cols, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::MatrixXd M(rows, cols);
  for (int c = 0; c < cols; ++c) {
    for (int r = 0; r < rows; ++r) M(r, c) = uniform(*rng);
  }
  return M;
}

/// A well-conditioned symmetric positive-definite matrix: 0.1 A A^T + 0.01 I.
inline Eigen::MatrixXd randomCovariance(int dim, std::mt19937* rng) {
  const Eigen::MatrixXd A = randomMatrix(dim, dim, rng);
  return 0.1 * A * A.transpose() + 0.01 * Eigen::MatrixXd::Identity(dim, dim);
}

}  // namespace testing
}  // namespace ekf_vislam
