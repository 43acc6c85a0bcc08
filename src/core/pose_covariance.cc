#include "ekf_vislam/core/pose_covariance.h"

#include "ekf_vislam/core/se3.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <vector>

namespace ekf_vislam {

namespace {

// A fifth-degree cubature rule for the standard normal in six dimensions (the points of Jia, Xin
// and Cheng's fifth-degree cubature Kalman filter): the centre, +-sqrt(n + 2) e_i and
// +-sqrt((n + 2) / 2) (e_i +- e_j), 73 points that integrate every polynomial up to the fifth
// degree exactly. A second moment of the errors, which are curved in the rotation, needs the
// fourth moments of pairs of axes too, which the 13 points of a plain unscented transform do not
// hold (its covariance stayed 3.5 times too narrow with a heading known to 0.5 rad).
struct CubatureRule {
  std::vector<Vector6d> points;
  std::vector<double> weights;

  CubatureRule() {
    constexpr int n = 6;
    const double axis = std::sqrt(n + 2.0), pair = std::sqrt((n + 2.0) / 2.0);
    add(Vector6d::Zero(), 2.0 / (n + 2));
    for (int i = 0; i < n; ++i) {
      for (const double sign : {1.0, -1.0}) {
        add(sign * axis * Vector6d::Unit(i), (4.0 - n) / (2.0 * (n + 2) * (n + 2)));
      }
    }
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        for (const double sign_i : {1.0, -1.0}) {
          for (const double sign_j : {1.0, -1.0}) {
            add(pair * (sign_i * Vector6d::Unit(i) + sign_j * Vector6d::Unit(j)),
                1.0 / ((n + 2) * (n + 2)));
          }
        }
      }
    }
  }
  void add(const Vector6d& point, double weight) {
    points.push_back(point);
    weights.push_back(weight);
  }
};

// A square root L (L L^T = P) of a covariance that may be only semi-definite.
Matrix6d squareRoot(const Matrix6d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (covariance + covariance.transpose()));
  const Vector6d roots = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eigen.eigenvectors() * roots.asDiagonal();
}

// The positive part of a symmetric matrix.
Matrix6d positivePart(const Matrix6d& m) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (m + m.transpose()));
  const Vector6d values = eigen.eigenvalues().cwiseMax(0.0);
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

}  // namespace

Matrix6d linearWorldPoseCovariance(const Matrix6d& eps_covariance, const Eigen::Vector3d& p_world) {
  // exp(eps^) T: position p + rho + phi x p, rotation exp(phi) R.
  Matrix6d M = Matrix6d::Identity();
  M.topRightCorner<3, 3>() = -se3::hat(p_world);
  return M * eps_covariance * M.transpose();
}

Matrix6d reportedWorldPoseCovariance(const Matrix6d& eps_covariance,
                                     const Eigen::Vector3d& p_world) {
  static const CubatureRule rule;
  const Matrix6d linear = linearWorldPoseCovariance(eps_covariance, p_world);
  const Matrix6d root = squareRoot(eps_covariance);
  Matrix6d second_moment = Matrix6d::Zero();
  for (size_t k = 0; k < rule.points.size(); ++k) {
    const Vector6d eps = root * rule.points[k];
    // exp(eps^) moves p to exp(phi) p + J_l(phi) rho.
    const Eigen::Matrix4d moved = se3::exp(eps);
    Vector6d error;
    error.head<3>() =
        moved.topLeftCorner<3, 3>() * p_world + moved.topRightCorner<3, 1>() - p_world;
    error.tail<3>() = eps.tail<3>();
    second_moment += rule.weights[k] * error * error.transpose();
  }
  return linear + positivePart(second_moment - linear);
}

}  // namespace ekf_vislam
