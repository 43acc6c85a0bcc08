#include "ekf_vislam/core/state_helper.h"

#include "ekf_vislam/core/se3.h"
#include "testing/random_matrices.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

using testing::randomCovariance;
using testing::randomMatrix;

// Pose, one gyro bias row, the disparity offset and three landmarks (17 rows), random means and
// a random SPD covariance.
FilterState makeState(std::mt19937* rng) {
  StateLayout layout;
  layout.bias_components = {5};
  layout.disparity_dim = 1;
  FilterState state(layout);
  state.reset(StatePrior());
  state.imu_T_world = se3::exp(Vector6d(randomMatrix(6, 1, rng)));
  state.bias(0) = 0.01;
  state.disparity_offset = 0.3;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d p_world = 10.0 * randomMatrix(3, 1, rng);
    state.appendLandmark(p_world, Eigen::MatrixXd::Zero(3, state.dim()),
                         Eigen::Matrix3d::Identity());
  }
  state.covariance() = randomCovariance(state.dim(), rng);
  return state;
}

// makeState's layout with a reported covariance beside the gains' one (another random SPD).
// A state of this layout (with the disparity offset) and three landmarks at random places.
FilterState withThreeLandmarks(StateLayout layout, std::mt19937* rng) {
  layout.disparity_dim = 1;
  FilterState state(layout);
  state.reset(StatePrior());
  for (int k = 0; k < 3; ++k) {
    state.appendLandmark(10.0 * Eigen::Vector3d(randomMatrix(3, 1, rng)),
                         Eigen::MatrixXd::Zero(3, state.dim()), Eigen::Matrix3d::Identity());
  }
  return state;
}

FilterState makeReportingState(std::mt19937* rng) {
  StateLayout layout;
  layout.bias_components = {5};
  layout.reported_covariance = true;
  FilterState state = withThreeLandmarks(layout, rng);
  state.covariance(0) = randomCovariance(state.dim(), rng);
  state.covariance(1) = randomCovariance(state.dim(), rng);
  return state;
}

JacobianBlock block(int first_row, int cols, std::mt19937* rng) {
  JacobianBlock b;
  b.first_row = first_row;
  b.H = randomMatrix(3, cols, rng);
  return b;
}

// Two 3-row observations: pose + disparity + landmark 0, and pose + landmark 2.
std::vector<SparseJacobian> twoObservations(const StateLayout& layout, std::mt19937* rng) {
  const SparseJacobian first = {block(0, 6, rng), block(layout.disparityRow(), 1, rng),
                                block(layout.landmarkRow(0), 3, rng)};
  const SparseJacobian second = {block(0, 6, rng), block(layout.landmarkRow(2), 3, rng)};
  return {first, second};
}

Eigen::MatrixXd denseJacobian(const std::vector<SparseJacobian>& jacobians, int dim) {
  int rows = 0;
  for (const SparseJacobian& jacobian : jacobians) rows += jacobian.front().H.rows();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(rows, dim);
  int row = 0;
  for (const SparseJacobian& jacobian : jacobians) {
    for (const JacobianBlock& b : jacobian) {
      H.block(row, b.first_row, b.H.rows(), b.H.cols()) += b.H;
    }
    row += jacobian.front().H.rows();
  }
  return H;
}

struct DenseUpdate {
  Eigen::VectorXd dx;
  Eigen::MatrixXd covariance;
};

// Textbook EKF: K = P H^T (H P H^T + R)^-1, dx = K r, P' = (I - K H) P.
DenseUpdate denseEkf(const Eigen::MatrixXd& P, const Eigen::MatrixXd& H, const Eigen::VectorXd& r,
                     double noise_var) {
  const Eigen::MatrixXd S =
      H * P * H.transpose() + noise_var * Eigen::MatrixXd::Identity(H.rows(), H.rows());
  const Eigen::MatrixXd K = P * H.transpose() * S.inverse();
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(P.rows(), P.cols());
  return {K * r, (I - K * H) * P};
}

void expectStateUnchanged(const FilterState& state, const FilterState& before) {
  EXPECT_EQ(state.dim(), before.dim());
  EXPECT_TRUE(state.covariance() == before.covariance());
  EXPECT_TRUE(state.imu_T_world == before.imu_T_world);
  EXPECT_TRUE(state.bias == before.bias);
  EXPECT_EQ(state.disparity_offset, before.disparity_offset);
  for (size_t k = 0; k < before.landmarkCount(); ++k) {
    EXPECT_TRUE(state.landmark(k) == before.landmark(k)) << "landmark " << k;
  }
}

TEST(StateHelper, UpdateMatchesTheDenseTextbookEkf) {
  std::mt19937 rng(1);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const StateLayout& layout = state.layout();
  const std::vector<SparseJacobian> jacobians = twoObservations(layout, &rng);
  const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);
  const double noise_var = 0.5;

  const UpdateOutcome outcome = state_helper::update(&state, jacobians, residual, noise_var, false);
  ASSERT_EQ(outcome.status, UpdateStatus::kApplied);
  EXPECT_FALSE(outcome.covariance_repaired);

  const DenseUpdate expected =
      denseEkf(before.covariance(), denseJacobian(jacobians, 17), residual, noise_var);
  const double scale = expected.covariance.norm();
  EXPECT_LT((state.covariance() - expected.covariance).norm(), 1e-9 * scale);
  // correct_pose = false: the pose stays, every other mean moves additively by its rows of dx.
  const Eigen::VectorXd& dx = expected.dx;
  const double tolerance = 1e-9 * dx.norm();
  EXPECT_TRUE(state.imu_T_world == before.imu_T_world);
  EXPECT_NEAR(state.bias(0) - before.bias(0), dx(layout.biasRow()), tolerance);
  EXPECT_NEAR(state.disparity_offset - before.disparity_offset, dx(layout.disparityRow()),
              tolerance);
  for (size_t k = 0; k < 3; ++k) {
    const Eigen::Vector3d moved = state.landmark(k) - before.landmark(k);
    EXPECT_LT((moved - dx.segment<3>(layout.landmarkRow(k))).norm(), tolerance) << "landmark " << k;
  }
  // Landmark 1 is observed by nobody but correlated: it moves too.
  EXPECT_GT((state.landmark(1) - before.landmark(1)).norm(), 1e-6);
}

TEST(StateHelper, UpdateWithPoseCorrectionMovesWorldTImuByTheExponential) {
  std::mt19937 rng(2);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const std::vector<SparseJacobian> jacobians = twoObservations(state.layout(), &rng);
  const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);

  ASSERT_EQ(state_helper::update(&state, jacobians, residual, 0.5, true).status,
            UpdateStatus::kApplied);
  const DenseUpdate expected =
      denseEkf(before.covariance(), denseJacobian(jacobians, 17), residual, 0.5);
  EXPECT_LT((state.covariance() - expected.covariance).norm(), 1e-9 * expected.covariance.norm());
  const Eigen::Matrix4d world_T_imu_expected =
      se3::exp(Vector6d(expected.dx.head<6>())) * se3::inverse(before.imu_T_world);
  EXPECT_LT((se3::inverse(state.imu_T_world) - world_T_imu_expected).norm(), 1e-9);
  EXPECT_GT(expected.dx.head<6>().norm(), 1e-3);
}

TEST(StateHelper, Mahalanobis2MatchesTheDenseInnovationCovariance) {
  std::mt19937 rng(3);
  const FilterState state = makeState(&rng);
  const SparseJacobian jacobian = twoObservations(state.layout(), &rng).front();
  const Eigen::VectorXd residual = randomMatrix(3, 1, &rng);
  const double noise_var = 0.7;

  const Eigen::MatrixXd H = denseJacobian({jacobian}, state.dim());
  const Eigen::MatrixXd S =
      H * state.covariance() * H.transpose() + noise_var * Eigen::MatrixXd::Identity(3, 3);
  const double expected = residual.dot(S.inverse() * residual);
  EXPECT_NEAR(state_helper::mahalanobis2(state, jacobian, residual, noise_var), expected,
              1e-10 * expected);
}

TEST(StateHelper, AugmentAppendsTheLinearizedLandmarkWithItsCrossCovariance) {
  std::mt19937 rng(4);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const int n = before.dim();
  const int head = before.layout().headDim();
  const Eigen::MatrixXd A = randomMatrix(3, head, &rng);
  const Eigen::Matrix3d own_covariance = randomCovariance(3, &rng);
  const Eigen::Vector3d p_world(4.0, -2.0, 7.0);

  state_helper::augment(&state, p_world, A, own_covariance);
  ASSERT_EQ(state.dim(), n + 3);
  ASSERT_EQ(state.landmarkCount(), 4u);
  EXPECT_TRUE(state.landmark(3) == p_world);
  const Eigen::MatrixXd P = before.covariance();
  const auto S = state.covariance();
  EXPECT_TRUE(S.topLeftCorner(n, n) == P);
  const Eigen::MatrixXd cross = A * P.topRows(head);
  EXPECT_LT((S.block(n, 0, 3, n) - cross).norm(), 1e-12);
  EXPECT_LT((S.block(0, n, n, 3) - cross.transpose()).norm(), 1e-12);
  const Eigen::Matrix3d own = A * P.topLeftCorner(head, head) * A.transpose() + own_covariance;
  EXPECT_LT((S.block<3, 3>(n, n) - own).norm(), 1e-12);
}

TEST(StateHelper, MarginalizeLandmarksKeepsTheOthersInOrder) {
  std::mt19937 rng(5);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const StateLayout& layout = state.layout();

  state_helper::marginalizeLandmarks(&state, {false, true, false});
  ASSERT_EQ(state.landmarkCount(), 2u);
  ASSERT_EQ(state.dim(), before.dim() - 3);
  std::vector<int> kept;
  for (int i = 0; i < layout.headDim(); ++i) kept.push_back(i);
  for (size_t k : {0u, 2u}) {
    for (int i = 0; i < 3; ++i) kept.push_back(layout.landmarkRow(k) + i);
  }
  const auto P = before.covariance();
  for (int r = 0; r < state.dim(); ++r) {
    for (int c = 0; c < state.dim(); ++c) {
      EXPECT_EQ(state.covariance()(r, c), P(kept[r], kept[c])) << r << ", " << c;
    }
  }
  EXPECT_TRUE(state.landmark(0) == before.landmark(0));
  EXPECT_TRUE(state.landmark(1) == before.landmark(2));
}

TEST(StateHelper, UpdateRefusesNonFiniteInputAndChangesNothing) {
  std::mt19937 rng(6);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const std::vector<SparseJacobian> jacobians = twoObservations(state.layout(), &rng);
  const double nan = std::numeric_limits<double>::quiet_NaN();

  Eigen::VectorXd residual = randomMatrix(6, 1, &rng);
  residual(4) = nan;
  EXPECT_EQ(state_helper::update(&state, jacobians, residual, 0.5, true).status,
            UpdateStatus::kNonFinite);
  expectStateUnchanged(state, before);

  residual(4) = 0.1;
  std::vector<SparseJacobian> bad_jacobians = jacobians;
  bad_jacobians[1][1].H(0, 2) = std::numeric_limits<double>::infinity();
  EXPECT_NE(state_helper::update(&state, bad_jacobians, residual, 0.5, true).status,
            UpdateStatus::kApplied);
  expectStateUnchanged(state, before);

  EXPECT_NE(state_helper::update(&state, jacobians, residual, nan, true).status,
            UpdateStatus::kApplied);
  expectStateUnchanged(state, before);
}

TEST(StateHelper, UpdateRefusesANonPositiveDefiniteInnovationAndChangesNothing) {
  std::mt19937 rng(7);
  FilterState state = makeState(&rng);
  const FilterState before = state;
  const std::vector<SparseJacobian> jacobians = twoObservations(state.layout(), &rng);
  const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);

  EXPECT_EQ(state_helper::update(&state, jacobians, residual, -1e3, true).status,
            UpdateStatus::kNotPositiveDefinite);
  expectStateUnchanged(state, before);
}

// Pose, a counted speed scale, the disparity offset and three landmarks (18 rows). The gains'
// covariance is random with the scale's row zero; the reported one is A + sigma^2 [b; 1] [b; 1]^T
// (A random with the scale's row zero): the state's error a + b c with c the scale's error.
struct ConsiderStates {
  FilterState state;
  Eigen::VectorXd b;  ///< sensitivity, zero in the scale's row
};
ConsiderStates makeConsiderState(double sigma, std::mt19937* rng) {
  StateLayout layout;
  layout.speed_scale_dim = 1;
  layout.reported_covariance = true;
  FilterState state = withThreeLandmarks(layout, rng);
  const int row = state.layout().speedScaleRow();
  Eigen::MatrixXd gains = randomCovariance(state.dim(), rng);
  gains.row(row).setZero();
  gains.col(row).setZero();
  Eigen::MatrixXd a = randomCovariance(state.dim(), rng);
  a.row(row).setZero();
  a.col(row).setZero();
  Eigen::VectorXd b = 10.0 * randomMatrix(state.dim(), 1, rng);
  b(row) = 0.0;
  Eigen::VectorXd with_scale = b;
  with_scale(row) = 1.0;
  state.covariance(0) = gains;
  state.covariance(1) = a + sigma * sigma * with_scale * with_scale.transpose();
  return {state, b};
}

TEST(StateHelper, ConsiderEvidenceReadsAnInnovationAlongTheSensitivity) {
  std::mt19937 rng(31);
  ConsiderStates s = makeConsiderState(0.01, &rng);
  const int row = s.state.layout().speedScaleRow();
  const std::vector<SparseJacobian> jacobians = twoObservations(s.state.layout(), &rng);
  const Eigen::MatrixXd H = denseJacobian(jacobians, s.state.dim());
  // An innovation that is the scale's error of -0.029 alone: the evidence reads it exactly.
  const double c = -0.029;
  const UpdateOutcome outcome =
      state_helper::update(&s.state, jacobians, H * s.b * c, 0.5, false, 2.0, {-1, row});
  ASSERT_EQ(outcome.status, UpdateStatus::kApplied);
  EXPECT_NEAR(outcome.consider[1].score / outcome.consider[1].information, c, 1e-12);
  EXPECT_EQ(outcome.consider[0].information, 0.0);
  // information = g^T S^-1 g with g = H b, S of the gains' covariance.
  ConsiderStates again = makeConsiderState(0.01, &(rng = std::mt19937(31)));
  const Eigen::MatrixXd S = H * again.state.covariance(0) * H.transpose() +
                            0.5 * Eigen::MatrixXd::Identity(H.rows(), H.rows());
  const Eigen::VectorXd g = H * again.b;
  EXPECT_NEAR(outcome.consider[1].information, g.dot(S.ldlt().solve(g)),
              1e-9 * outcome.consider[1].information);
  // Without a consider row: no evidence.
  EXPECT_EQ(state_helper::update(&s.state, jacobians, H * s.b * c, 0.5, false, 2.0)
                .consider[1]
                .information,
            0.0);
}

TEST(StateHelper, SetConsiderSigmaEqualsThePriorOfThatSigma) {
  // The same updates from a 1 % and a 3 % prior of the counted scale; the first then set to 3 %:
  // the two reported covariances agree (and the gains' ones never differed).
  std::mt19937 rng_a(41), rng_b(41);
  ConsiderStates a = makeConsiderState(0.01, &rng_a);
  ConsiderStates b = makeConsiderState(0.03, &rng_b);
  std::mt19937 rng(42);
  for (int k = 0; k < 3; ++k) {
    const std::vector<SparseJacobian> jacobians = twoObservations(a.state.layout(), &rng);
    const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);
    ASSERT_EQ(state_helper::update(&a.state, jacobians, residual, 0.5, true, 3.0).status,
              UpdateStatus::kApplied);
    ASSERT_EQ(state_helper::update(&b.state, jacobians, residual, 0.5, true, 3.0).status,
              UpdateStatus::kApplied);
  }
  const int row = a.state.layout().speedScaleRow();
  a.state.setConsiderSigma(row, 0.03);
  const Eigen::MatrixXd expected = b.state.covariance(1);
  EXPECT_LT((Eigen::MatrixXd(a.state.covariance(1)) - expected).norm(), 1e-9 * expected.norm());
  EXPECT_TRUE(Eigen::MatrixXd(a.state.covariance(0)) == Eigen::MatrixXd(b.state.covariance(0)));
  EXPECT_NEAR(std::sqrt(a.state.covariance(1)(row, row)), 0.03, 1e-15);
}

TEST(StateHelper, SetReportedVarianceAlongWidensTheBlockAndWhatItExplains) {
  // A reported covariance A S A^T + N, with S the covariance of two rows and N independent of
  // them: widening those rows along u by d must give A (S + d u u^T) A^T + N, the gains'
  // covariance untouched.
  std::mt19937 rng(43);
  FilterState state = makeReportingState(&rng);
  const int dim = state.dim(), row = 7;
  const Eigen::MatrixXd S = randomCovariance(2, &rng);
  Eigen::MatrixXd A = randomMatrix(dim, 2, &rng);
  A.middleRows(row, 2).setIdentity();
  Eigen::MatrixXd N = randomCovariance(dim, &rng);
  N.middleRows(row, 2).setZero();
  N.middleCols(row, 2).setZero();
  state.covariance(1) = A * S * A.transpose() + N;
  const Eigen::MatrixXd gains = state.covariance(0);
  const Eigen::Vector2d u = Eigen::Vector2d(0.6, -0.8);
  const double widened = u.dot(S * u) + 0.3;
  state.setReportedVarianceAlong(row, 2, u, widened);
  const Eigen::MatrixXd expected = A * (S + 0.3 * u * u.transpose()) * A.transpose() + N;
  EXPECT_LT((Eigen::MatrixXd(state.covariance(1)) - expected).norm(), 1e-12 * expected.norm());
  EXPECT_NEAR(u.dot(state.covariance(1).block<2, 2>(row, row) * u), widened, 1e-12);
  EXPECT_TRUE(Eigen::MatrixXd(state.covariance(0)) == gains);
}

TEST(StateHelper, ReportedCovarianceFollowsTheGainsOfTheOtherInJosephForm) {
  std::mt19937 rng(11);
  FilterState state = makeReportingState(&rng);
  const FilterState before = state;
  const std::vector<SparseJacobian> jacobians = twoObservations(state.layout(), &rng);
  const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);
  const double noise_var = 0.5;
  const double reported_noise_var = 7.0;
  ASSERT_EQ(state_helper::update(&state, jacobians, residual, noise_var, false, reported_noise_var)
                .status,
            UpdateStatus::kApplied);

  // The gains' covariance and the means: the ordinary update.
  const Eigen::MatrixXd H = denseJacobian(jacobians, 17);
  const DenseUpdate expected = denseEkf(before.covariance(0), H, residual, noise_var);
  EXPECT_LT((state.covariance(0) - expected.covariance).norm(), 1e-9 * expected.covariance.norm());
  // The reported one: (I - K H) P_r (I - K H)^T + K R_r K^T with K of the gains' covariance.
  const Eigen::MatrixXd P = before.covariance(0);
  const Eigen::MatrixXd S = H * P * H.transpose() + noise_var * Eigen::MatrixXd::Identity(6, 6);
  const Eigen::MatrixXd K = P * H.transpose() * S.inverse();
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(17, 17) - K * H;
  const Eigen::MatrixXd joseph =
      A * before.covariance(1) * A.transpose() + reported_noise_var * K * K.transpose();
  EXPECT_LT((Eigen::MatrixXd(state.covariance(1)) - joseph).norm(), 1e-9 * joseph.norm());
  EXPECT_TRUE(Eigen::MatrixXd(state.covariance(1)).isApprox(state.covariance(1).transpose()));
}

TEST(StateHelper, ReportedCovarianceEqualsTheOtherWhenNoiseAndStartAgree) {
  // Joseph form with the optimal gain is the ordinary update.
  std::mt19937 rng(12);
  FilterState state = makeReportingState(&rng);
  state.covariance(1) = state.covariance(0);
  const std::vector<SparseJacobian> jacobians = twoObservations(state.layout(), &rng);
  ASSERT_EQ(state_helper::update(&state, jacobians, randomMatrix(6, 1, &rng), 0.5, true).status,
            UpdateStatus::kApplied);
  const Eigen::MatrixXd P0 = state.covariance(0);
  EXPECT_LT((Eigen::MatrixXd(state.covariance(1)) - P0).norm(), 1e-9 * P0.norm());
}

TEST(StateHelper, AugmentAndMarginalizeKeepBothCovariances) {
  std::mt19937 rng(13);
  FilterState state = makeReportingState(&rng);
  const FilterState before = state;
  const int head = state.layout().headDim();
  const Eigen::MatrixXd A_head = randomMatrix(3, head, &rng);
  const Eigen::Matrix3d own = Eigen::Matrix3d::Identity() * 0.3;
  state_helper::augment(&state, Eigen::Vector3d(1.0, 2.0, 3.0), A_head, own);
  for (int which = 0; which < 2; ++which) {
    const auto S = before.covariance(which);
    const auto S_new = state.covariance(which);
    const Eigen::MatrixXd cross = A_head * S.topRows(head);
    EXPECT_LT((S_new.bottomLeftCorner(3, before.dim()) - cross).norm(), 1e-12) << which;
    const Eigen::Matrix3d expected_own =
        own + A_head * S.topLeftCorner(head, head) * A_head.transpose();
    EXPECT_LT((S_new.bottomRightCorner<3, 3>() - expected_own).norm(), 1e-12) << which;
  }
  state_helper::marginalizeLandmarks(&state, {false, true, false, true});
  for (int which = 0; which < 2; ++which) {
    EXPECT_TRUE(state.covariance(which).topLeftCorner(head + 3, head + 3) ==
                before.covariance(which).topLeftCorner(head + 3, head + 3))
        << which;
    const Eigen::Matrix3d kept = before.covariance(which).block(head + 6, head + 6, 3, 3);
    EXPECT_TRUE(state.covariance(which).bottomRightCorner(3, 3) == kept) << which;
  }
}

TEST(StateHelper, FoldingTheTrackNoiseRecountsEveryTrackUpdateAtOneFactor) {
  // Two states alike: one's reported covariance counts its track updates at the pixel variance
  // (no correlation estimate yet), the other's at 20 times it. Predictions, an augmentation, an
  // update that is not the tracks' (its noise the same in both) and a marginalization in
  // between; after the fold at 20 the two reported covariances agree.
  std::mt19937 rng(17);
  StateLayout layout;
  layout.bias_components = {5};
  layout.reported_covariance = true;
  FilterState learning = withThreeLandmarks(layout, &rng);
  learning.covariance(0) = randomCovariance(learning.dim(), &rng);
  learning.covariance(1) = randomCovariance(learning.dim(), &rng);
  ASSERT_TRUE(learning.carriesTrackNoise());
  ASSERT_EQ(learning.carriedCount(), 3);
  FilterState known = learning;
  const double pixel_var = 0.5;
  const double factor = 20.0;
  const int aux = learning.layout().auxDim();
  const Eigen::MatrixXd gain = randomMatrix(6, aux, &rng);
  const Matrix6d noise = randomCovariance(6, &rng);
  const Eigen::VectorXd walk = Eigen::VectorXd::Constant(aux, 0.01);
  const Eigen::MatrixXd A_head = randomMatrix(3, learning.layout().headDim(), &rng);
  const auto trackUpdate = [&](FilterState* state, double counted) {
    const std::vector<SparseJacobian> jacobians = twoObservations(state->layout(), &rng);
    const Eigen::VectorXd residual = randomMatrix(6, 1, &rng);
    return state_helper::update(state, jacobians, residual, pixel_var, true, counted * pixel_var,
                                kNoConsiderRows, true)
        .status;
  };
  for (FilterState* state : {&learning, &known}) {
    std::mt19937 same(23);  // the same observations in both
    std::swap(rng, same);
    const bool learns = state == &learning;
    state->deferPrediction(gain, noise, walk, true);
    ASSERT_EQ(trackUpdate(state, learns ? 1.0 : factor), UpdateStatus::kApplied);
    state_helper::augment(state, Eigen::Vector3d(1.0, 2.0, 30.0), A_head,
                          0.3 * Eigen::Matrix3d::Identity());
    const std::vector<SparseJacobian> prior = twoObservations(state->layout(), &rng);
    ASSERT_EQ(state_helper::update(state, prior, randomMatrix(6, 1, &rng), 2.0, true, 2.0).status,
              UpdateStatus::kApplied);
    state->deferPrediction(gain, noise, walk, true);
    ASSERT_EQ(trackUpdate(state, learns ? 1.0 : factor), UpdateStatus::kApplied);
    state_helper::marginalizeLandmarks(state, {false, true, false, false});
    std::swap(rng, same);
  }
  learning.foldTrackNoise(factor);
  EXPECT_FALSE(learning.carriesTrackNoise());
  EXPECT_EQ(learning.carriedCount(), 2);
  const Eigen::MatrixXd expected = known.covariance(1);
  EXPECT_LT((Eigen::MatrixXd(learning.covariance(1)) - expected).norm(), 1e-9 * expected.norm());
  EXPECT_TRUE(learning.covariance(0) == known.covariance(0));
  // Without the parts' map (the recount applied to the last update alone) it would not agree.
  EXPECT_GT((Eigen::MatrixXd(learning.covariance(1)) - learning.covariance(0)).norm(),
            1e-3 * expected.norm());
}

TEST(StateHelper, ReportedCovarianceIsTheErrorCovarianceOfTheMismatchedGain) {
  // A static 3-vector observed 20 times with noise of std 2 while the gains assume 0.5: the
  // reported covariance (noise 4) must match the spread of the errors over many trials, while
  // the gains' covariance is 16 times too small.
  std::mt19937 rng(14);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int trials = 4000;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d reported = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d gains = Eigen::Matrix3d::Zero();
  for (int trial = 0; trial < trials; ++trial) {
    StateLayout layout;
    layout.reported_covariance = true;
    FilterState state(layout);
    StatePrior prior;
    prior.position_sigma = 1.0;
    prior.rotation_sigma = 1.0;
    state.reset(prior);
    const Eigen::Vector3d truth(normal(rng), normal(rng), normal(rng));
    // The landmark's prior: mean 0, covariance I, appended without cross terms.
    state.appendLandmark(Eigen::Vector3d::Zero(), Eigen::MatrixXd::Zero(3, state.dim()),
                         Eigen::Matrix3d::Identity());
    const int row = state.layout().landmarkRow(0);
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d z =
          truth + 2.0 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      const Eigen::Vector3d r = z - state.landmark(0);
      ASSERT_EQ(
          state_helper::update(&state, {{{row, Eigen::Matrix3d::Identity()}}}, r, 0.25, false, 4.0)
              .status,
          UpdateStatus::kApplied);
    }
    const Eigen::Vector3d error = state.landmark(0) - truth;
    scatter += error * error.transpose() / trials;
    reported += state.covariance(1).block<3, 3>(row, row) / trials;
    gains += state.covariance(0).block<3, 3>(row, row) / trials;
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(scatter(i, i) / reported(i, i), 1.0, 0.1) << i;
    EXPECT_GT(scatter(i, i) / gains(i, i), 8.0) << i;
  }
}

}  // namespace
}  // namespace ekf_vislam
