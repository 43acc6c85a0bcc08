#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>

#include <random>

namespace ekf_vislam {
namespace {

Vector6d randomTwist(std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Vector6d xi;
  for (int i = 0; i < 6; ++i) xi(i) = u(*rng);
  return xi;
}

TEST(Se3, HatVeeRoundTrip) {
  std::mt19937 rng(1);
  const Vector6d xi = randomTwist(&rng, 1.0);
  EXPECT_LT((se3::vee(se3::hat(xi)) - xi).norm(), 1e-15);
  const Eigen::Vector3d w = xi.head<3>();
  EXPECT_LT((se3::hat(w) * Eigen::Vector3d(1, 2, 3) - w.cross(Eigen::Vector3d(1, 2, 3))).norm(),
            1e-14);
}

TEST(Se3, ExpLogRoundTripIncludingSmallAndLargeAngles) {
  std::mt19937 rng(2);
  for (double scale : {1e-9, 1e-6, 1e-3, 0.1, 1.0, 3.0}) {
    for (int i = 0; i < 50; ++i) {
      Vector6d xi = randomTwist(&rng, scale);
      if (xi.tail<3>().norm() > 3.1) xi.tail<3>() *= 3.1 / xi.tail<3>().norm();
      const Eigen::Matrix4d T = se3::exp(xi);
      EXPECT_LT((se3::log(T) - xi).norm(), 1e-9 * std::max(1.0, xi.norm())) << "scale " << scale;
      EXPECT_LT((T.topLeftCorner<3, 3>().transpose() * T.topLeftCorner<3, 3>() -
                 Eigen::Matrix3d::Identity())
                    .norm(),
                1e-12);
    }
  }
}

TEST(Se3, ExpMatchesMatrixExponentialSeries) {
  std::mt19937 rng(3);
  const Vector6d xi = randomTwist(&rng, 0.8);
  const Eigen::Matrix4d A = se3::hat(xi);
  Eigen::Matrix4d sum = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
  for (int n = 1; n < 30; ++n) {
    term = term * A / n;
    sum += term;
  }
  EXPECT_LT((se3::exp(xi) - sum).norm(), 1e-12);
}

TEST(Se3, LogSO3NearPi) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -1).normalized();
  const Eigen::Vector3d phi = (M_PI - 1e-7) * axis;
  EXPECT_LT((se3::logSO3(se3::expSO3(phi)) - phi).norm(), 1e-5);
}

TEST(Se3, AdjointConjugatesTwists) {
  std::mt19937 rng(4);
  const Eigen::Matrix4d T = se3::exp(randomTwist(&rng, 1.0));
  const Vector6d xi = randomTwist(&rng, 0.5);
  const Eigen::Matrix4d lhs = T * se3::exp(xi) * se3::inverse(T);
  const Eigen::Matrix4d rhs = se3::exp(se3::adjoint(T) * xi);
  EXPECT_LT((lhs - rhs).norm(), 1e-12);
  // exp of the curly hat is the adjoint of the exp (used by the covariance prediction).
  const Matrix6d curly = se3::curlyHat(xi);
  Matrix6d sum = Matrix6d::Identity(), term = Matrix6d::Identity();
  for (int n = 1; n < 40; ++n) {
    term = term * curly / n;
    sum += term;
  }
  EXPECT_LT((sum - se3::adjoint(se3::exp(xi))).norm(), 1e-11);
  // Adjoint of a product and of an inverse.
  const Eigen::Matrix4d S = se3::exp(randomTwist(&rng, 1.0));
  EXPECT_LT((se3::adjoint(T * S) - se3::adjoint(T) * se3::adjoint(S)).norm(), 1e-12);
  EXPECT_LT((se3::adjoint(se3::inverse(T)) - se3::adjoint(T).inverse()).norm(), 1e-10);
}

TEST(Se3, LeftJacobianAgainstCentralDifferences) {
  std::mt19937 rng(5);
  for (double scale : {1e-5, 0.05, 0.7, 2.0}) {
    const Vector6d xi = randomTwist(&rng, scale);
    const Matrix6d J = se3::leftJacobian(xi);
    const Eigen::Matrix4d T0_inv = se3::inverse(se3::exp(xi));
    Matrix6d numeric;
    const double h = 1e-6;
    for (int i = 0; i < 6; ++i) {
      Vector6d d = Vector6d::Zero();
      d(i) = h;
      numeric.col(i) =
          (se3::log(se3::exp(xi + d) * T0_inv) - se3::log(se3::exp(xi - d) * T0_inv)) / (2 * h);
    }
    EXPECT_LT((J - numeric).norm(), 1e-7) << "scale " << scale;
  }
}

TEST(Se3, OdotMatchesHatTimesPoint) {
  std::mt19937 rng(6);
  const Vector6d xi = randomTwist(&rng, 1.0);
  const Eigen::Vector4d s(1.5, -2.0, 0.3, 1.0);
  EXPECT_LT((se3::hat(xi) * s - se3::odot(s) * xi).norm(), 1e-14);
}

}  // namespace
}  // namespace ekf_vislam
