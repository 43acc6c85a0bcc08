#include "ekf_vislam/core/twist_at_rest.h"

#include <Eigen/Cholesky>

#include <limits>
#include <vector>

namespace ekf_vislam {

double distanceFromRest2(const Propagator& propagator, const TwistData& twist,
                         const FilterState& state) {
  const Vector6d u = propagator.correctedTwist(state, twist);
  const Eigen::LDLT<Matrix6d> ldlt(propagator.sampleCovariance(state, twist));
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all()) {
    return std::numeric_limits<double>::infinity();
  }
  return u.dot(ldlt.solve(u));
}

std::optional<UpdateStatus> updateGyroBiasAtRest(const Propagator& propagator,
                                                 const TwistData& twist, double sample_period,
                                                 FilterState* state) {
  const StateLayout& layout = state->layout();
  if (layout.auxDim() == 0 || !(sample_period > 0.0)) return std::nullopt;
  const Vector6d u = propagator.correctedTwist(*state, twist);
  const Eigen::MatrixXd H = propagator.twistJacobian(*state, twist, u).bottomRows<3>();
  if (H.isZero(0.0)) return std::nullopt;
  const Eigen::Matrix3d noise =
      propagator.noiseDensity(*state, twist).bottomRightCorner<3, 3>() / sample_period;
  const Eigen::LLT<Eigen::Matrix3d> llt(noise);
  if (llt.info() != Eigen::Success) return std::nullopt;
  // Whitened (L^-1 r, L^-1 H, unit noise): the update takes a scalar noise variance.
  const Eigen::Vector3d residual = llt.matrixL().solve(Eigen::Vector3d(-u.tail<3>()));
  const Eigen::MatrixXd H_white = llt.matrixL().solve(H);
  const std::vector<SparseJacobian> jacobians{{{StateLayout::kPoseDim, H_white}}};
  // The gyro's noise is no track error: the reported covariance takes the same noise.
  return state_helper::update(state, jacobians, residual, 1.0, true, 1.0).status;
}

}  // namespace ekf_vislam
