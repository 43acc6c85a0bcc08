#include "ekf_vislam/core/inverse_depth_retraction.h"

#include <gtest/gtest.h>
#include <Eigen/LU>

namespace ekf_vislam {
namespace {

constexpr double kFx = 718.856, kCx = 607.19, kFy = 718.856, kCy = 185.22, kBaseline = 0.537;

// [uL, v, uR] of a camera-frame point and its Jacobian.
Eigen::Vector3d observe(const Eigen::Vector3d& q) {
  return Eigen::Vector3d(kFx * q.x() / q.z() + kCx, kFy * q.y() / q.z() + kCy,
                         kFx * (q.x() - kBaseline) / q.z() + kCx);
}
Eigen::Matrix3d observationJacobian(const Eigen::Vector3d& q) {
  const double z = q.z();
  Eigen::Matrix3d H;
  H << kFx / z, 0.0, -kFx * q.x() / (z * z),  //
      0.0, kFy / z, -kFy * q.y() / (z * z),   //
      kFx / z, 0.0, -kFx * (q.x() - kBaseline) / (z * z);
  return H;
}

TEST(InverseDepthRetraction, LandsWhereTheLinearizedStereoObservationSaid) {
  // An update that asks for a change dz of the observation moves the point by dq = H^-1 dz to
  // first order. Along the inverse-depth line the observation changes by dz exactly, at any
  // depth; along the Cartesian line it does not, and far points come out too near.
  const Eigen::Vector3d dz(3.0, -1.5, 5.0);  // the disparity falls by 2 px
  for (const double depth : {5.0, 20.0, 60.0}) {
    const Eigen::Vector3d q(4.0, 1.5, depth);
    const Eigen::Vector3d dq = observationJacobian(q).inverse() * dz;
    const Eigen::Vector3d moved = inverse_depth_retraction::move(q, dq);
    EXPECT_LT((observe(moved) - observe(q) - dz).norm(), 1e-9) << "depth " << depth;
    const double cartesian_error = (observe(q + dq) - observe(q) - dz).norm();
    EXPECT_GT(cartesian_error, 0.01) << "depth " << depth;
    EXPECT_GT(moved.z(), (q + dq).z()) << "depth " << depth;
  }
}

TEST(InverseDepthRetraction, AgreesWithTheCartesianMoveToFirstOrder) {
  const Eigen::Vector3d q(-3.0, 1.0, 30.0), dq(0.4, -0.2, 6.0);
  double previous = 0.0;
  for (const double scale : {1e-1, 1e-2, 1e-3}) {
    const double bend = (inverse_depth_retraction::move(q, scale * dq) - (q + scale * dq)).norm();
    EXPECT_LT(bend, 0.1 * scale * dq.norm());
    if (previous > 0.0) {
      EXPECT_NEAR(bend / previous, 0.01, 0.002);  // second order
    }
    previous = bend;
  }
}

TEST(InverseDepthRetraction, MovesCartesianBehindTheCameraNearItOrBeyondFiveTimesTheDepth) {
  const Eigen::Vector3d dq(0.5, 0.1, 3.0);
  for (const Eigen::Vector3d& q :
       {Eigen::Vector3d(1.0, 0.0, -10.0), Eigen::Vector3d(1.0, 0.0, 0.5)}) {
    EXPECT_EQ(inverse_depth_retraction::move(q, dq), q + dq);
  }
  // dr = -r^2 dz: at 10 m a step of 8.5 m along z takes r to 0.15 r.
  const Eigen::Vector3d q(1.0, 0.0, 10.0), far(0.0, 0.0, 8.5);
  EXPECT_EQ(inverse_depth_retraction::move(q, far), q + far);
  EXPECT_NE(inverse_depth_retraction::move(q, 0.5 * far), q + 0.5 * far);
}

}  // namespace
}  // namespace ekf_vislam
