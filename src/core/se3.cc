#include "ekf_vislam/core/se3.h"

#include <Eigen/SVD>

#include <cmath>

namespace ekf_vislam {
namespace se3 {
namespace {
constexpr double kSmallAngle = 1e-6;
}  // namespace

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return m;
}

Eigen::Vector3d vee(const Eigen::Matrix3d& w_hat) {
  return Eigen::Vector3d(w_hat(2, 1), w_hat(0, 2), w_hat(1, 0));
}

Eigen::Matrix4d hat(const Vector6d& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = hat(Eigen::Vector3d(xi.tail<3>()));
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

Vector6d vee(const Eigen::Matrix4d& xi_hat) {
  Vector6d xi;
  xi.head<3>() = xi_hat.topRightCorner<3, 1>();
  xi.tail<3>() = vee(Eigen::Matrix3d(xi_hat.topLeftCorner<3, 3>()));
  return xi;
}

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double a, b;
  if (theta2 < kSmallAngle * kSmallAngle) {
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  const double cos_theta = std::max(-1.0, std::min(1.0, 0.5 * (R.trace() - 1.0)));
  const double theta = std::acos(cos_theta);
  const Eigen::Vector3d w(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  if (theta < kSmallAngle) return 0.5 * (1.0 + theta * theta / 6.0) * w;
  if (M_PI - theta < 1e-5) {
    // Near pi: axis from the symmetric part R + I = 2 a a^T (1 - cos) ~ 2 a a^T.
    const Eigen::Matrix3d B = 0.5 * (R + Eigen::Matrix3d::Identity());
    int i;
    B.diagonal().maxCoeff(&i);
    Eigen::Vector3d axis = B.col(i) / std::sqrt(std::max(B(i, i), 1e-300));
    axis.normalize();
    if (axis.dot(w) < 0.0) axis = -axis;
    return theta * axis;
  }
  return theta / (2.0 * std::sin(theta)) * w;
}

Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double a, b;
  if (theta2 < kSmallAngle * kSmallAngle) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = (1.0 - std::cos(theta)) / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Matrix3d leftJacobianInverseSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = hat(phi);
  double c;
  if (theta2 < 1e-8) {
    c = 1.0 / 12.0 + theta2 / 720.0;
  } else {
    const double theta = std::sqrt(theta2);
    c = (1.0 - 0.5 * theta * std::sin(theta) / (1.0 - std::cos(theta))) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * K + c * K * K;
}

Eigen::Matrix4d exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = expSO3(phi);
  T.topRightCorner<3, 1>() = leftJacobianSO3(phi) * rho;
  return T;
}

Vector6d log(const Eigen::Matrix4d& T) {
  Vector6d xi;
  const Eigen::Vector3d phi = logSO3(T.topLeftCorner<3, 3>());
  xi.tail<3>() = phi;
  xi.head<3>() = leftJacobianInverseSO3(phi) * T.topRightCorner<3, 1>();
  return xi;
}

Matrix6d adjoint(const Eigen::Matrix4d& T) {
  Matrix6d ad = Matrix6d::Zero();
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  ad.topLeftCorner<3, 3>() = R;
  ad.bottomRightCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = hat(Eigen::Vector3d(T.topRightCorner<3, 1>())) * R;
  return ad;
}

Matrix6d curlyHat(const Vector6d& xi) {
  Matrix6d m = Matrix6d::Zero();
  const Eigen::Matrix3d phi_hat = hat(Eigen::Vector3d(xi.tail<3>()));
  m.topLeftCorner<3, 3>() = phi_hat;
  m.bottomRightCorner<3, 3>() = phi_hat;
  m.topRightCorner<3, 3>() = hat(Eigen::Vector3d(xi.head<3>()));
  return m;
}

Matrix6d leftJacobian(const Vector6d& xi) {
  // Closed form (Barfoot, State Estimation for Robotics, 7.86): J = [[J3, Q], [0, J3]].
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const Eigen::Matrix3d P = hat(phi);
  const Eigen::Matrix3d Rh = hat(rho);
  const double theta2 = phi.squaredNorm();
  double c1, c2, c3;
  if (theta2 < 1e-6) {
    c1 = 1.0 / 6.0 - theta2 / 120.0;
    c2 = -1.0 / 24.0 + theta2 / 720.0;
    c3 = -1.0 / 120.0 + theta2 / 2520.0;
  } else {
    const double t = std::sqrt(theta2);
    const double s = std::sin(t), c = std::cos(t);
    c1 = (t - s) / (theta2 * t);
    c2 = (theta2 + 2.0 * c - 2.0) / (2.0 * theta2 * theta2);
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * theta2 * theta2 * t);
  }
  const Eigen::Matrix3d PR = P * Rh;
  const Eigen::Matrix3d RP = Rh * P;
  const Eigen::Matrix3d PRP = PR * P;
  const Eigen::Matrix3d Q = 0.5 * Rh + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - 3.0 * PRP) +
                            c3 * (PRP * P + P * PRP);
  Matrix6d J = Matrix6d::Zero();
  const Eigen::Matrix3d J3 = leftJacobianSO3(phi);
  J.topLeftCorner<3, 3>() = J3;
  J.bottomRightCorner<3, 3>() = J3;
  J.topRightCorner<3, 3>() = Q;
  return J;
}

Eigen::Matrix<double, 4, 6> odot(const Eigen::Vector4d& s_h) {
  Eigen::Matrix<double, 4, 6> m = Eigen::Matrix<double, 4, 6>::Zero();
  m.topLeftCorner<3, 3>() = s_h(3) * Eigen::Matrix3d::Identity();
  m.topRightCorner<3, 3>() = -hat(Eigen::Vector3d(s_h.head<3>()));
  return m;
}

Eigen::Matrix4d inverse(const Eigen::Matrix4d& T) {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d Rt = T.topLeftCorner<3, 3>().transpose();
  inv.topLeftCorner<3, 3>() = Rt;
  inv.topRightCorner<3, 1>() = -Rt * T.topRightCorner<3, 1>();
  return inv;
}

void normalizeRotation(Eigen::Matrix4d* T) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(T->topLeftCorner<3, 3>(),
                                        Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0.0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1.0;
    R = U * svd.matrixV().transpose();
  }
  T->topLeftCorner<3, 3>() = R;
  T->row(3) << 0.0, 0.0, 0.0, 1.0;
}

}  // namespace se3
}  // namespace ekf_vislam
