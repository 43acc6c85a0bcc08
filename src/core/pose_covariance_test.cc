#include "ekf_vislam/core/pose_covariance.h"

#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <cstdio>
#include <random>

namespace ekf_vislam {
namespace {

// The world-axes error [p_true - p; phi] of the pose exp(eps^) T at position p (rotation errors
// as the estimator reports them).
Vector6d exactError(const Vector6d& eps, const Eigen::Vector3d& p) {
  const Eigen::Vector3d rho = eps.head<3>(), phi = eps.tail<3>();
  Vector6d error;
  error << se3::expSO3(phi) * p + se3::leftJacobianSO3(phi) * rho - p, phi;
  return error;
}

// A covariance of eps with the given sigmas (rho x, y, z, phi x, y, z) and a correlation between
// rho and phi, as a filter's pose covariance has.
Matrix6d epsCovariance(const Vector6d& sigmas) {
  Matrix6d correlation = Matrix6d::Identity();
  correlation(1, 5) = correlation(5, 1) = 0.6;
  correlation(2, 4) = correlation(4, 2) = -0.4;
  return sigmas.asDiagonal() * correlation * sigmas.asDiagonal();
}

// Mean NEES over draws of eps ~ N(0, eps_covariance) of their exact errors against `reported`.
double meanNees(const Matrix6d& eps_covariance, const Eigen::Vector3d& p,
                const Matrix6d& reported) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  const Matrix6d root = eps_covariance.llt().matrixL();
  const auto solver = reported.ldlt();
  double sum = 0;
  constexpr int kDraws = 20000;
  for (int k = 0; k < kDraws; ++k) {
    Vector6d z;
    for (int i = 0; i < 6; ++i) z(i) = normal(random);
    const Vector6d error = exactError(root * z, p);
    sum += error.dot(solver.solve(error));
  }
  return sum / kDraws;
}

TEST(PoseCovariance, TheLinearMapIsTheExactErrorsJacobian) {
  const Eigen::Vector3d p(120.0, -35.0, 4.0);
  Matrix6d J;
  const double h = 1e-7;
  for (int i = 0; i < 6; ++i) {
    Vector6d eps = Vector6d::Zero();
    eps(i) = h;
    J.col(i) = (exactError(eps, p) - exactError(-eps, p)) / (2 * h);
  }
  // J P J^T for P = I is M M^T.
  EXPECT_LT((linearWorldPoseCovariance(Matrix6d::Identity(), p) - J * J.transpose()).norm(),
            1e-5 * (J * J.transpose()).norm());
}

TEST(PoseCovariance, ASmallRotationUncertaintyReportsTheLinearCovariance) {
  // SLAM's order of magnitude: 0.3 m and 5 mrad at 400 m from the origin.
  const Eigen::Vector3d p(400.0, 30.0, -2.0);
  Vector6d sigmas;
  sigmas << 0.3, 0.3, 0.2, 0.005, 0.005, 0.005;
  const Matrix6d P = epsCovariance(sigmas);
  const Matrix6d linear = linearWorldPoseCovariance(P, p);
  const Matrix6d reported = reportedWorldPoseCovariance(P, p);
  EXPECT_LT((reported - linear).norm(), 1e-3 * linear.norm());
  EXPECT_NEAR(meanNees(P, p, reported), 6.0, 0.15);
  EXPECT_NEAR(meanNees(P, p, linear), 6.0, 0.15);
  EXPECT_EQ(reportedWorldPoseCovariance(Matrix6d::Zero(), p), Matrix6d::Zero());
}

TEST(PoseCovariance, ALargeRotationUncertaintyIsReportedWithItsCurvedSpread) {
  // Dead reckoning far from the start with an unobservable gyro bias: the heading known to 0.5
  // rad. The linear covariance is thin along p, where the rotation's curvature puts errors of
  // tens of metres: its NEES is far from 6; the reported one's is near 6, not above it.
  const Eigen::Vector3d p(200.0, 10.0, 0.0);
  Vector6d sigmas;
  sigmas << 1.0, 1.0, 1.0, 0.1, 0.1, 0.5;
  const Matrix6d P = epsCovariance(sigmas);
  const Matrix6d linear = linearWorldPoseCovariance(P, p);
  const Matrix6d reported = reportedWorldPoseCovariance(P, p);
  const double nees_linear = meanNees(P, p, linear), nees_reported = meanNees(P, p, reported);
  std::printf("mean NEES (6 is consistent): linear %.2f, reported %.2f\n", nees_linear,
              nees_reported);
  EXPECT_GT(nees_linear, 1000.0);
  EXPECT_LT(nees_reported, 6.5);
  EXPECT_GT(nees_reported, 4.0);
  // Never narrower than the linear covariance in any direction.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> excess(reported - linear);
  EXPECT_GT(excess.eigenvalues().minCoeff(), -1e-9 * linear.norm());
  EXPECT_GT(excess.eigenvalues().maxCoeff(), 1.0);
}

}  // namespace
}  // namespace ekf_vislam
