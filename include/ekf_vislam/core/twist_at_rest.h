// A twist sample while the camera stands still (standstill/): whether it agrees with rest, and
// the gyro bias it measures. No ROS.
#pragma once

#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/propagator.h"
#include "ekf_vislam/core/state_helper.h"
#include "ekf_vislam/core/types.h"

#include <optional>

namespace ekf_vislam {

/// How far a sample is from rest: u^T S^-1 u, u = Propagator::correctedTwist (what the filter
/// would integrate), S its covariance (Propagator::sampleCovariance: the sample's noise and the
/// estimated bias's). Chi-square with 6 degrees of freedom at rest; infinite when S is singular.
double distanceFromRest2(const Propagator& propagator, const TwistData& twist,
                         const FilterState& state);

/// At rest the true angular rate is 0, so a twist sample's rate measures the gyro bias: the
/// update of the corrected rate u_w = R_m (w_m - b_w) (Propagator::correctedTwist) against 0,
/// H = d u_w / d (auxiliary states), with the sample's own noise (the propagator's density over
/// sample_period). The pose's rotation, correlated with the bias by the earlier predictions,
/// follows. Nothing (no value) when no auxiliary state moves the rate or the noise is zero.
std::optional<UpdateStatus> updateGyroBiasAtRest(const Propagator& propagator,
                                                 const TwistData& twist, double sample_period,
                                                 FilterState* state);

}  // namespace ekf_vislam
