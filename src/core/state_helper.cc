#include "ekf_vislam/core/state_helper.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <map>
#include <utility>
#include <vector>

namespace ekf_vislam {
namespace state_helper {
namespace {

/// The stacked Jacobian arranged for the two products of an update. A variable several
/// observations touch (the pose, the calibration, ...) gets one m x k matrix with the blocks
/// of all of them (zero rows elsewhere): one matrix product. A block of a variable only one
/// observation touches (its landmark) stays on its own: k column operations.
struct ArrangedJacobian {
  struct Shared {
    int first_row;
    Eigen::MatrixXd H;  // m x k
  };
  struct Single {
    int row;        // first residual row
    int first_row;  // first state column
    const Eigen::MatrixXd* H;
  };
  int m = 0;
  std::vector<Shared> shared;
  std::vector<Single> single;
};

ArrangedJacobian arrange(const std::vector<SparseJacobian>& jacobians) {
  ArrangedJacobian arranged;
  std::map<std::pair<int, int>, int> uses;  // (first column, columns) -> observations
  for (const SparseJacobian& jacobian : jacobians) {
    arranged.m += static_cast<int>(jacobian.front().H.rows());
    for (const JacobianBlock& block : jacobian) {
      ++uses[{block.first_row, static_cast<int>(block.H.cols())}];
    }
  }
  std::map<std::pair<int, int>, int> shared_index;
  for (const auto& [key, count] : uses) {
    if (count < 2) continue;
    shared_index[key] = static_cast<int>(arranged.shared.size());
    arranged.shared.push_back({key.first, Eigen::MatrixXd::Zero(arranged.m, key.second)});
  }
  int row = 0;
  for (const SparseJacobian& jacobian : jacobians) {
    for (const JacobianBlock& block : jacobian) {
      const auto it = shared_index.find({block.first_row, static_cast<int>(block.H.cols())});
      if (it == shared_index.end()) {
        arranged.single.push_back({row, block.first_row, &block.H});
      } else {
        arranged.shared[it->second].H.middleRows(row, block.H.rows()) += block.H;
      }
    }
    row += static_cast<int>(jacobian.front().H.rows());
  }
  return arranged;
}

/// out.middleCols(out_col, H.rows()) += in.middleCols(in_col, H.cols()) * H^T, one column
/// operation per entry of H (contiguous columns: vectorized).
template <typename Out, typename In>
void addTimesTransposed(const Eigen::MatrixXd& H, const In& in, int in_col, int out_col, Out* out) {
  for (int j = 0; j < H.rows(); ++j) {
    for (int i = 0; i < H.cols(); ++i) out->col(out_col + j) += H(j, i) * in.col(in_col + i);
  }
}

/// P H^T (dim x m) of a covariance, from the touched columns only.
Eigen::MatrixXd covarianceTimesHt(const ArrangedJacobian& jacobian,
                                  const Eigen::Block<Eigen::MatrixXd>& P) {
  Eigen::MatrixXd PHt = Eigen::MatrixXd::Zero(P.rows(), jacobian.m);
  for (const auto& shared : jacobian.shared) {
    PHt.noalias() += P.middleCols(shared.first_row, shared.H.cols()) * shared.H.transpose();
  }
  for (const auto& single : jacobian.single) {
    addTimesTransposed(*single.H, P, single.first_row, single.row, &PHt);
  }
  return PHt;
}

/// H P H^T + R (m x m) from P H^T, as (P H^T)^T H^T (the same matrix: symmetric).
Eigen::MatrixXd innovationCovariance(const ArrangedJacobian& jacobian, const Eigen::MatrixXd& PHt,
                                     double noise_var) {
  const Eigen::MatrixXd HP = PHt.transpose();  // the rows of P H^T as contiguous columns
  Eigen::MatrixXd innovation_cov = Eigen::MatrixXd::Zero(jacobian.m, jacobian.m);
  for (const auto& shared : jacobian.shared) {
    innovation_cov.noalias() +=
        HP.middleCols(shared.first_row, shared.H.cols()) * shared.H.transpose();
  }
  for (const auto& single : jacobian.single) {
    addTimesTransposed(*single.H, HP, single.first_row, single.row, &innovation_cov);
  }
  innovation_cov.diagonal().array() += noise_var;
  return innovation_cov;
}

/// Copies the lower triangle (the one the rank update of the gains' covariance maintains) into
/// the upper.
void mirrorLowerTriangle(Eigen::Block<Eigen::MatrixXd> P) {
  const int dim = static_cast<int>(P.rows());
  for (int j = 1; j < dim; ++j) P.col(j).head(j) = P.row(j).head(j).transpose();
}

/// The reported covariance after an update with the gain K of the other one (Joseph form):
/// P <- (I - K H) P (I - K H)^T + K R K^T = P + K C^T + C K^T with C = K S / 2 - P H^T and
/// S = H P H^T + R: the covariance of that gain's error when the noise is R = noise_var I.
void updateReported(const ArrangedJacobian& jacobian, const Eigen::MatrixXd& K,
                    const Eigen::MatrixXd& PHt, double noise_var, Eigen::Block<Eigen::MatrixXd> P) {
  const Eigen::MatrixXd C = 0.5 * K * innovationCovariance(jacobian, PHt, noise_var) - PHt;
  // K C^T + C K^T as one product and its transpose: exactly symmetric, and a general product
  // runs faster than the two symmetric rank-m updates of the same flop count.
  Eigen::MatrixXd KCt(P.rows(), P.cols());
  KCt.noalias() = K * C.transpose();
  P += KCt + KCt.transpose();
}

}  // namespace

Eigen::MatrixXd innovationCovariance(const FilterState& state, const SparseJacobian& jacobian,
                                     double noise_var) {
  int columns = 0;
  for (const JacobianBlock& block : jacobian) columns += static_cast<int>(block.H.cols());
  const int rows = jacobian.empty() ? 0 : static_cast<int>(jacobian.front().H.rows());
  Eigen::MatrixXd H(rows, columns);
  std::vector<int> index;
  index.reserve(columns);
  int used = 0;
  for (const JacobianBlock& block : jacobian) {
    H.middleCols(used, block.H.cols()) = block.H;
    used += static_cast<int>(block.H.cols());
    for (int a = 0; a < block.H.cols(); ++a) index.push_back(block.first_row + a);
  }
  const auto S = state.covariance();
  Eigen::MatrixXd sub(columns, columns);
  for (int a = 0; a < columns; ++a) {
    for (int b = 0; b < columns; ++b) sub(a, b) = S(index[a], index[b]);
  }
  Eigen::MatrixXd innovation_cov = H * sub * H.transpose();
  innovation_cov.diagonal().array() += noise_var;
  return innovation_cov;
}

double mahalanobis2(const FilterState& state, const SparseJacobian& jacobian,
                    const Eigen::VectorXd& residual, double noise_var) {
  return residual.dot(innovationCovariance(state, jacobian, noise_var).ldlt().solve(residual));
}

UpdateOutcome update(FilterState* state, const std::vector<SparseJacobian>& jacobians,
                     const Eigen::VectorXd& residual, double noise_var, bool correct_pose,
                     double reported_noise_var, const ConsiderRows& consider_rows,
                     bool track_observations) {
  UpdateOutcome outcome;
  auto S = state->covariance();
  const ArrangedJacobian arranged = arrange(jacobians);
  const Eigen::MatrixXd PHt = covarianceTimesHt(arranged, S);
  Eigen::LLT<Eigen::MatrixXd> llt(innovationCovariance(arranged, PHt, noise_var));
  if (llt.info() != Eigen::Success) {
    outcome.status = UpdateStatus::kNotPositiveDefinite;
    return outcome;
  }
  // B = L^-1 (P H^T)^T; dx = B^T L^-1 r; Sigma -= B^T B (symmetric by construction).
  const Eigen::MatrixXd B = llt.matrixL().solve(PHt.transpose());
  const Eigen::VectorXd w = llt.matrixL().solve(residual);
  const Eigen::VectorXd dx = B.transpose() * w;
  if (!dx.allFinite() || !B.allFinite()) {
    outcome.status = UpdateStatus::kNonFinite;
    return outcome;
  }
  if (state->covarianceCount() > 1) {
    // K^T = S^-1 (P H^T)^T = L^-T B.
    const Eigen::MatrixXd K = llt.matrixU().solve(B).transpose();
    auto reported = state->covariance(1);
    const Eigen::MatrixXd reported_PHt = covarianceTimesHt(arranged, reported);
    for (int k = 0; k < kMaxConsiderRows; ++k) {
      const int row = consider_rows[k];
      const double consider_var = row >= 0 ? reported(row, row) : 0.0;
      if (!(consider_var > 0.0)) continue;
      // g = H P[:, row] / P(row, row): the row of P H^T (P symmetric), scaled.
      const Eigen::VectorXd u =
          llt.matrixL().solve(Eigen::VectorXd(reported_PHt.row(row).transpose())) / consider_var;
      outcome.consider[k].score = u.dot(w);
      outcome.consider[k].information = u.squaredNorm();
    }
    const double counted_var = reported_noise_var < 0.0 ? noise_var : reported_noise_var;
    updateReported(arranged, K, reported_PHt, counted_var, reported);
    if (state->carriesTrackNoise()) {
      // The track-noise part takes the gain's map, and the noise only of the tracks.
      auto part = state->covariance(FilterState::kTrackNoise);
      updateReported(arranged, K, covarianceTimesHt(arranged, part),
                     track_observations ? noise_var : 0.0, part);
    }
  }
  S.selfadjointView<Eigen::Lower>().rankUpdate(B.transpose(), -1.0);
  mirrorLowerTriangle(S);
  state->applyCorrection(dx, correct_pose);
  // Guard: the diagonal must stay positive. A row that is exactly zero is a variable no update
  // may move (a counted speed scale in the gains' covariance): nothing to repair there.
  for (int which = 0; which < state->covarianceCount(); ++which) {
    auto C = state->covariance(which);
    for (Eigen::Index i = 0; i < C.rows(); ++i) {
      if (C(i, i) > 0.0 || C.row(i).isZero(0.0)) continue;
      outcome.covariance_repaired = true;
      C(i, i) = std::max(C(i, i), 1e-12);
    }
  }
  return outcome;
}

void augment(FilterState* state, const Eigen::Vector3d& p_world, const Eigen::MatrixXd& A_head,
             const Eigen::Matrix3d& own_covariance) {
  // Cov(x_new, state) = A Sigma_[head, :]: O(head x dim), not O(dim^2).
  const int head = static_cast<int>(A_head.cols());
  std::vector<Eigen::MatrixXd> crosses;
  std::vector<Eigen::Matrix3d> owns;
  for (int which = 0; which < state->carriedCount(); ++which) {
    const auto S = state->covariance(which);
    crosses.push_back(A_head * S.topRows(head));
    owns.push_back(crosses.back().leftCols(head) * A_head.transpose());
    // The landmark's own noise (its first observation's) is not an update's: not in the parts.
    if (which < state->covarianceCount()) owns.back() += own_covariance;
  }
  state->appendLandmark(p_world, crosses, owns);
}

void marginalizeLandmarks(FilterState* state, const std::vector<bool>& remove) {
  const StateLayout& layout = state->layout();
  std::vector<int> keep_rows;
  keep_rows.reserve(state->dim());
  for (int i = 0; i < layout.headDim(); ++i) keep_rows.push_back(i);
  for (size_t k = 0; k < remove.size(); ++k) {
    if (remove[k]) continue;
    const int row = layout.landmarkRow(k);
    for (int i = 0; i < 3; ++i) keep_rows.push_back(row + i);
  }
  state->keepRows(keep_rows);
}

}  // namespace state_helper
}  // namespace ekf_vislam
