// Generic EKF operations on a FilterState, touching only the variables a Jacobian names: the
// Mahalanobis distance of one observation, the stacked update, augmentation with a new
// landmark and marginalization. No ROS.
#pragma once

#include "ekf_vislam/core/filter_state.h"

#include <Eigen/Core>

#include <array>
#include <vector>

namespace ekf_vislam {

/// The Jacobian of an observation with respect to one variable: the state columns
/// first_row .. first_row + H.cols() - 1.
struct JacobianBlock {
  int first_row = 0;
  Eigen::MatrixXd H;
};
/// An observation's Jacobian: only the blocks it touches (every block has the same rows). The
/// blocks' order and sizes fix the floating-point summation order.
using SparseJacobian = std::vector<JacobianBlock>;

enum class UpdateStatus { kApplied, kNotPositiveDefinite, kNonFinite };

/// What an update's innovation r says of one consider variable (a row the reported covariance
/// alone carries) c, which no update moves. The reported covariance's column of the row, over its
/// variance, is the sensitivity b of the state's error to c; g = H b. Then score = g^T S^-1 r and
/// information = g^T S^-1 g (S of the gains' covariance), so that sum(score) / sum(information)
/// over updates estimates c, with variance 1 / sum(information) when the innovations are white.
struct ConsiderEvidence {
  double score = 0.0;
  double information = 0.0;
};

/// The consider rows an update reads (update's consider_rows; -1: none), at most two.
constexpr int kMaxConsiderRows = 2;
using ConsiderRows = std::array<int, kMaxConsiderRows>;
constexpr ConsiderRows kNoConsiderRows = {-1, -1};

struct UpdateOutcome {
  UpdateStatus status = UpdateStatus::kApplied;
  bool covariance_repaired = false;  ///< a diagonal entry was not positive and was floored
  /// Per consider row of the update (same order): what the innovation says of it.
  std::array<ConsiderEvidence, kMaxConsiderRows> consider{};
};

namespace state_helper {

/// H Sigma H^T + noise_var I over the touched variables only (the gains' covariance).
Eigen::MatrixXd innovationCovariance(const FilterState& state, const SparseJacobian& jacobian,
                                     double noise_var);
/// r^T (H Sigma H^T + noise_var I)^-1 r over the touched variables only.
double mahalanobis2(const FilterState& state, const SparseJacobian& jacobian,
                    const Eigen::VectorXd& residual, double noise_var);

/// Joint EKF update with the observations stacked (residuals stacked in the same order, each
/// observation's rows equal to its blocks' rows), noise noise_var I. Covariance through the
/// Cholesky factor of the innovation covariance (symmetric by construction), then
/// FilterState::applyCorrection(dx, correct_pose). Nothing changes unless kApplied.
/// With a reported covariance (FilterState::covarianceCount() 2), that one is updated with the
/// same gain in the Joseph form for observation noise reported_noise_var I (negative: noise_var):
/// the covariance of this gain's error when the noise is that large. consider_rows (rows the
/// reported covariance alone carries, -1: none): the outcome's consider evidence of each. The
/// track-noise part (FilterState::carriesTrackNoise) takes the same gain, and noise_var only
/// when track_observations (the image's tracks; while the part is carried reported_noise_var
/// must count them at noise_var too, FilterState::foldTrackNoise).
UpdateOutcome update(FilterState* state, const std::vector<SparseJacobian>& jacobians,
                     const Eigen::VectorXd& residual, double noise_var, bool correct_pose,
                     double reported_noise_var = -1.0,
                     const ConsiderRows& consider_rows = kNoConsiderRows,
                     bool track_observations = false);

/// Appends a landmark whose error is x_new = A x_head + n (A: 3 x head dim, only pose and
/// auxiliary columns non-zero; n: independent, covariance own_covariance).
void augment(FilterState* state, const Eigen::Vector3d& p_world, const Eigen::MatrixXd& A_head,
             const Eigen::Matrix3d& own_covariance);

/// Marginalizes the landmarks whose flag is set (flags: one per landmark).
void marginalizeLandmarks(FilterState* state, const std::vector<bool>& remove);

}  // namespace state_helper
}  // namespace ekf_vislam
