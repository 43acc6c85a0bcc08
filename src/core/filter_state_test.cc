#include "ekf_vislam/core/filter_state.h"

#include "ekf_vislam/core/inverse_depth_retraction.h"
#include "ekf_vislam/core/se3.h"
#include "testing/random_matrices.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

using testing::randomMatrix;

// Gyro bias on all three axes, twist rotation, disparity offset, baseline scale and the clone.
StateLayout fullLayout() {
  StateLayout layout;
  layout.bias_components = {3, 4, 5};
  layout.rotation_dim = 3;
  layout.disparity_dim = 1;
  layout.scale_dim = 1;
  layout.clone_dim = 6;
  return layout;
}

StatePrior testPrior() {
  StatePrior prior;
  prior.position_sigma = 0.5;
  prior.rotation_sigma = 0.1;
  prior.velocity_bias_sigma = 0.3;
  prior.gyro_bias_sigma = 0.02;
  prior.twist_rotation_sigma = 0.05;
  prior.disparity_offset_sigma = 1.5;
  prior.baseline_scale_sigma = 0.04;
  return prior;
}

// fullLayout() after reset, random means, `landmarks` landmarks, random covariance.
FilterState randomState(int landmarks, std::mt19937* rng) {
  FilterState state(fullLayout());
  state.reset(testPrior());
  for (int k = 0; k < landmarks; ++k) {
    state.appendLandmark(10.0 * randomMatrix(3, 1, rng), Eigen::MatrixXd::Zero(3, state.dim()),
                         Eigen::Matrix3d::Identity());
  }
  const Eigen::MatrixXd A = randomMatrix(state.dim(), state.dim(), rng);
  state.covariance() = A * A.transpose();
  state.imu_T_world = se3::exp(Vector6d(randomMatrix(6, 1, rng)));
  state.imu_T_world_clone = se3::exp(Vector6d(randomMatrix(6, 1, rng)));
  state.bias = 0.1 * randomMatrix(3, 1, rng);
  state.imu_R_twist = se3::expSO3(0.1 * randomMatrix(3, 1, rng));
  state.disparity_offset = 0.7;
  state.baseline_scale_error = 0.02;
  return state;
}

// The head rows of fullLayout() (20) and the rows of these landmarks.
std::vector<int> headAndLandmarkRows(const std::vector<int>& landmarks) {
  std::vector<int> rows;
  for (int i = 0; i < 20; ++i) rows.push_back(i);
  for (int k : landmarks) {
    for (int i = 0; i < 3; ++i) rows.push_back(20 + 3 * k + i);
  }
  return rows;
}

Eigen::MatrixXd selectRows(const Eigen::MatrixXd& P, const std::vector<int>& rows) {
  const int n = static_cast<int>(rows.size());
  Eigen::MatrixXd selected(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) selected(r, c) = P(rows[r], rows[c]);
  }
  return selected;
}

TEST(FilterState, LayoutRowsOfEveryVariable) {
  const StateLayout layout = fullLayout();
  EXPECT_EQ(layout.biasDim(), 3);
  EXPECT_EQ(layout.biasRow(), 6);
  EXPECT_EQ(layout.rotationRow(), 9);
  EXPECT_EQ(layout.calibrationRow(), 12);
  EXPECT_EQ(layout.calibrationDim(), 2);
  EXPECT_EQ(layout.disparityRow(), 12);
  EXPECT_EQ(layout.scaleRow(), 13);
  EXPECT_EQ(layout.auxDim(), 8);
  EXPECT_EQ(layout.cloneRow(), 14);
  EXPECT_EQ(layout.headDim(), 20);
  EXPECT_EQ(layout.landmarkRow(0), 20);
  EXPECT_EQ(layout.landmarkRow(2), 26);
}

TEST(FilterState, LayoutBlocksTileTheRowsInOrderForEveryCombination) {
  const std::vector<std::vector<int>> bias_sets = {{}, {5}, {0, 1, 2, 3, 4, 5}};
  for (const std::vector<int>& bias : bias_sets) {
    for (int flags = 0; flags < 32; ++flags) {
      StateLayout layout;
      layout.bias_components = bias;
      layout.speed_scale_dim = (flags & 16) ? 1 : 0;
      layout.rotation_dim = (flags & 1) ? 3 : 0;
      layout.disparity_dim = (flags & 2) ? 1 : 0;
      layout.scale_dim = (flags & 4) ? 1 : 0;
      layout.clone_dim = (flags & 8) ? 6 : 0;
      // (first row, size) in the documented order; each must start where the previous ended.
      const std::vector<std::pair<int, int>> blocks = {
          {StateLayout::kPoseRow, StateLayout::kPoseDim},
          {layout.biasRow(), layout.biasDim()},
          {layout.speedScaleRow(), layout.speed_scale_dim},
          {layout.rotationRow(), layout.rotation_dim},
          {layout.disparityRow(), layout.disparity_dim},
          {layout.scaleRow(), layout.scale_dim},
          {layout.cloneRow(), layout.clone_dim},
          {layout.landmarkRow(0), 3},
          {layout.landmarkRow(1), 3}};
      int next = 0;
      for (const auto& b : blocks) {
        EXPECT_EQ(b.first, next) << "flags " << flags << " bias " << bias.size();
        next = b.first + b.second;
      }
      EXPECT_EQ(layout.headDim(), layout.landmarkRow(0));
      EXPECT_EQ(layout.auxDim(), layout.cloneRow() - StateLayout::kPoseDim);
    }
  }
}

TEST(FilterState, ResetGivesThePriorDiagonalWithTheCloneEqualToThePose) {
  std::mt19937 rng(1);
  FilterState state = randomState(2, &rng);
  state.reset(testPrior());
  ASSERT_EQ(state.dim(), 20);
  EXPECT_EQ(state.landmarkCount(), 0u);
  EXPECT_TRUE(state.imu_T_world == Eigen::Matrix4d::Identity());
  EXPECT_TRUE(state.imu_R_twist == Eigen::Matrix3d::Identity());
  EXPECT_TRUE(state.bias.isZero(0.0));
  EXPECT_EQ(state.disparity_offset, 0.0);
  Eigen::VectorXd pose(6);
  pose << 0.25, 0.25, 0.25, 0.01, 0.01, 0.01;
  Eigen::VectorXd diagonal(20);
  diagonal << pose, 4e-4, 4e-4, 4e-4, 2.5e-3, 2.5e-3, 2.5e-3, 2.25, 1.6e-3, pose;
  Eigen::MatrixXd expected = diagonal.asDiagonal();
  expected.block(14, 0, 6, 6) = Eigen::MatrixXd(pose.asDiagonal());
  expected.block(0, 14, 6, 6) = Eigen::MatrixXd(pose.asDiagonal());
  EXPECT_LT((state.covariance() - expected).norm(), 1e-15);
}

TEST(FilterState, SpeedScaleFollowsTheBiasWithItsPriorAndTakesItsCorrection) {
  StateLayout layout;
  layout.bias_components = {0, 4};
  layout.speed_scale_dim = 1;
  layout.rotation_dim = 3;
  FilterState state(layout);
  StatePrior prior = testPrior();
  prior.speed_scale_sigma = 0.05;
  state.reset(prior);
  ASSERT_EQ(layout.speedScaleRow(), 8);
  EXPECT_DOUBLE_EQ(state.covariance()(8, 8), 0.0025);
  EXPECT_DOUBLE_EQ(state.covariance()(9, 9), 0.0025);  // the twist rotation's 0.05^2 after it
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(state.dim());
  dx(8) = -0.03;
  state.applyCorrection(dx, true);
  EXPECT_DOUBLE_EQ(state.speed_scale_error, -0.03);
  EXPECT_TRUE(state.bias.isZero(0.0));
  EXPECT_TRUE(state.imu_R_twist == Eigen::Matrix3d::Identity());
  state.reset(prior);
  EXPECT_EQ(state.speed_scale_error, 0.0);
}

TEST(FilterState, ACountedSpeedScaleStartsInTheReportedCovarianceAlone) {
  StateLayout layout;
  layout.speed_scale_dim = 1;
  layout.reported_covariance = true;
  FilterState state(layout);
  StatePrior prior = testPrior();
  prior.speed_scale_sigma = 0.01;
  prior.speed_scale_reported_only = true;
  state.reset(prior);
  const int row = layout.speedScaleRow();
  EXPECT_TRUE(state.covariance(0).row(row).isZero(0.0));  // the gains never see it
  EXPECT_DOUBLE_EQ(state.covariance(1)(row, row), 1e-4);
  // Without a reported covariance (dead reckoning) the one covariance carries it.
  layout.reported_covariance = false;
  FilterState single(layout);
  single.reset(prior);
  EXPECT_DOUBLE_EQ(single.covariance()(row, row), 1e-4);
}

TEST(FilterState, SetPriorPicksVelocityOrGyroSigmaPerBiasComponent) {
  StateLayout layout;
  layout.bias_components = {0, 4};
  FilterState state(layout);
  state.reset(testPrior());
  EXPECT_DOUBLE_EQ(state.covariance()(6, 6), 0.09);
  EXPECT_DOUBLE_EQ(state.covariance()(7, 7), 4e-4);
  state.bias << 0.1, 0.2;
  Vector6d expected;
  expected << 0.1, 0.0, 0.0, 0.0, 0.2, 0.0;
  EXPECT_TRUE(state.biasVector() == expected);
}

TEST(FilterState, SetPriorIsIsotropicInWorldPositionAndAttitudeAboutThePose) {
  FilterState state{StateLayout()};
  state.reset(testPrior());
  Vector6d xi;
  xi << 3.0, -2.0, 1.0, 0.3, -0.2, 0.5;
  const Eigen::Matrix4d world_T_imu = se3::exp(xi);
  state.imu_T_world = se3::inverse(world_T_imu);
  state.setPrior(testPrior());
  // M: error eps -> (delta p_world, delta theta_world), by central differences.
  Matrix6d M;
  const double h = 1e-6;
  for (int j = 0; j < 6; ++j) {
    const Vector6d e = h * Vector6d::Unit(j);
    const Eigen::Matrix4d plus = se3::exp(e) * world_T_imu;
    const Eigen::Matrix4d minus = se3::exp(-e) * world_T_imu;
    M.block<3, 1>(0, j) = (plus - minus).topRightCorner<3, 1>() / (2 * h);
    const Eigen::Matrix3d R_rel =
        plus.topLeftCorner<3, 3>() * minus.topLeftCorner<3, 3>().transpose();
    M.block<3, 1>(3, j) = se3::logSO3(R_rel) / (2 * h);
  }
  Vector6d diagonal;
  diagonal << 0.25, 0.25, 0.25, 0.01, 0.01, 0.01;
  const Matrix6d sigma_out = M * state.covariance() * M.transpose();
  EXPECT_LT((sigma_out - Matrix6d(diagonal.asDiagonal())).norm(), 1e-8);
  EXPECT_GT((state.covariance() - Matrix6d(diagonal.asDiagonal())).norm(), 0.1);
}

TEST(FilterState, AppendLandmarkThenKeepRowsKeepsTheChosenBlocks) {
  std::mt19937 rng(2);
  FilterState state(fullLayout());
  state.reset(testPrior());
  std::vector<Eigen::Vector3d> p_world;
  for (int k = 0; k < 3; ++k) {
    const int row = state.dim();
    const Eigen::MatrixXd cross = randomMatrix(3, row, &rng);
    const Eigen::Matrix3d own = randomMatrix(3, 3, &rng);
    p_world.push_back(randomMatrix(3, 1, &rng));
    state.appendLandmark(p_world.back(), cross, own);
    ASSERT_EQ(state.dim(), row + 3);
    EXPECT_TRUE(state.covariance().block(row, 0, 3, row) == cross);
    EXPECT_TRUE(state.covariance().block(0, row, row, 3) == cross.transpose());
    EXPECT_TRUE(state.covariance().block(row, row, 3, 3) == own);
  }
  ASSERT_EQ(state.landmarkCount(), 3u);
  const Eigen::MatrixXd full = state.covariance();
  const std::vector<int> rows = headAndLandmarkRows({1, 2});
  state.keepRows(rows);
  ASSERT_EQ(state.landmarkCount(), 2u);
  EXPECT_TRUE(state.landmark(0) == p_world[1]);
  EXPECT_TRUE(state.landmark(1) == p_world[2]);
  EXPECT_TRUE(state.covariance() == selectRows(full, rows));
}

TEST(FilterState, AddGravityRowsInsertsThemBeforeTheCloneAndKeepsEverythingElse) {
  std::mt19937 rng(4);
  FilterState state = randomState(3, &rng);
  const Eigen::MatrixXd before = state.covariance();
  std::vector<Eigen::Vector3d> p_world;
  for (size_t k = 0; k < state.landmarkCount(); ++k) p_world.push_back(state.landmark(k));
  const int insert = state.layout().cloneRow();
  state.addGravityRows(0.2, 0.1);
  ASSERT_EQ(state.layout().gravity_dim, 5);
  EXPECT_EQ(state.layout().levelRow(), insert);
  EXPECT_EQ(state.layout().accelBiasRow(), insert + 2);
  EXPECT_EQ(state.layout().cloneRow(), insert + 5);
  ASSERT_EQ(state.dim(), static_cast<int>(before.rows()) + 5);
  // The old rows, in their new places, hold what they held.
  std::vector<int> old_rows;
  for (int r = 0; r < state.dim(); ++r) {
    if (r < insert || r >= insert + 5) old_rows.push_back(r);
  }
  EXPECT_TRUE(selectRows(state.covariance(), old_rows) == before);
  const Eigen::MatrixXd S = state.covariance();
  for (int i = 0; i < 5; ++i) {
    const int row = insert + i;
    EXPECT_EQ(S(row, row), i < 2 ? 0.2 * 0.2 : 0.1 * 0.1);
    EXPECT_EQ(S.row(row).cwiseAbs().sum(), S(row, row)) << "uncorrelated";
  }
  for (size_t k = 0; k < p_world.size(); ++k) EXPECT_TRUE(state.landmark(k) == p_world[k]);
  state.addGravityRows(0.2, 0.1);  // once only
  EXPECT_EQ(state.dim(), static_cast<int>(before.rows()) + 5);
}

TEST(FilterState, GrowingAndShrinkingTheStoragePreservesEveryEntry) {
  std::mt19937 rng(3);
  FilterState state(fullLayout());
  state.reset(testPrior());
  for (int k = 0; k < 100; ++k) {  // 320 rows: the storage grows three times
    state.appendLandmark(randomMatrix(3, 1, &rng), randomMatrix(3, state.dim(), &rng),
                         randomMatrix(3, 3, &rng));
  }
  const Eigen::MatrixXd full = state.covariance();
  const FilterState grown = state;
  const std::vector<int> rows = headAndLandmarkRows({7, 93});
  state.keepRows(rows);  // 26 of 320 rows: the storage shrinks
  ASSERT_EQ(state.dim(), 26);
  EXPECT_TRUE(state.landmark(0) == grown.landmark(7));
  EXPECT_TRUE(state.landmark(1) == grown.landmark(93));
  const Eigen::MatrixXd expected = selectRows(full, rows);
  EXPECT_TRUE(state.covariance() == expected);
  const Eigen::Vector3d p_world(1.0, 2.0, 3.0);
  state.appendLandmark(p_world, Eigen::MatrixXd::Zero(3, 26), Eigen::Matrix3d::Identity());
  EXPECT_TRUE(state.covariance().topLeftCorner(26, 26) == expected);
  EXPECT_TRUE(state.landmark(2) == p_world);
}

TEST(FilterState, ClonePoseGivesTheCloneThePoseMeanAndError) {
  std::mt19937 rng(4);
  FilterState state = randomState(2, &rng);
  const Eigen::MatrixXd before = state.covariance();
  state.clonePose();
  EXPECT_TRUE(state.imu_T_world_clone == state.imu_T_world);
  // The clone error is the pose error: J maps the old errors to the new ones.
  const int clone_row = state.layout().cloneRow();
  Eigen::MatrixXd J = Eigen::MatrixXd::Identity(state.dim(), state.dim());
  J.block(clone_row, 0, 6, state.dim()).setZero();
  J.block(clone_row, 0, 6, 6).setIdentity();
  EXPECT_LT((state.covariance() - J * before * J.transpose()).norm(), 1e-12 * before.norm());
  EXPECT_TRUE(state.covariance().block(clone_row, 0, 6, 6) == before.topLeftCorner(6, 6));
}

TEST(FilterState, ClonePoseWithoutCloneRowsCopiesOnlyTheMean) {
  FilterState state{StateLayout()};
  state.reset(testPrior());
  state.imu_T_world = se3::exp(Vector6d::Constant(0.3));
  const Eigen::MatrixXd before = state.covariance();
  state.clonePose();
  EXPECT_TRUE(state.imu_T_world_clone == state.imu_T_world);
  EXPECT_TRUE(state.covariance() == before);
}

// exp of the SE_2(3)-like matrix [[phi^, rho, xi], [0, 0, 0], [0, 0, 0]] (5x5), by its series.
Eigen::Matrix<double, 5, 5> extendedExp(const Vector6d& eps, const Eigen::Vector3d& xi) {
  Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Zero();
  A.topLeftCorner<3, 3>() = se3::hat(Eigen::Vector3d(eps.tail<3>()));
  A.block<3, 1>(0, 3) = eps.head<3>();
  A.block<3, 1>(0, 4) = xi;
  Eigen::Matrix<double, 5, 5> sum = Eigen::Matrix<double, 5, 5>::Identity(), term = sum;
  for (int n = 1; n < 30; ++n) {
    term = term * A / n;
    sum += term;
  }
  return sum;
}

void expectAuxiliaryCorrected(const FilterState& state, const FilterState& before,
                              const Eigen::VectorXd& dx) {
  const Eigen::Matrix4d world_T_clone =
      se3::exp(Vector6d(dx.segment<6>(14))) * se3::inverse(before.imu_T_world_clone);
  EXPECT_LT((se3::inverse(state.imu_T_world_clone) - world_T_clone).norm(), 1e-12);
  EXPECT_LT((state.bias - before.bias - dx.segment<3>(6)).norm(), 1e-15);
  const Eigen::Matrix3d R_m = se3::expSO3(dx.segment<3>(9)) * before.imu_R_twist;
  EXPECT_LT((state.imu_R_twist - R_m).norm(), 1e-14);
  EXPECT_DOUBLE_EQ(state.disparity_offset, before.disparity_offset + dx(12));
  EXPECT_DOUBLE_EQ(state.baseline_scale_error, before.baseline_scale_error + dx(13));
}

TEST(FilterState, ApplyCorrectionWithoutPoseAddsTheLandmarkErrors) {
  std::mt19937 rng(5);
  FilterState state = randomState(2, &rng);
  const FilterState before = state;
  const Eigen::VectorXd dx = 0.3 * randomMatrix(state.dim(), 1, &rng);
  state.applyCorrection(dx, false);
  EXPECT_TRUE(state.imu_T_world == before.imu_T_world);
  expectAuxiliaryCorrected(state, before, dx);
  for (size_t k = 0; k < 2; ++k) {
    const Eigen::Vector3d p_world = before.landmark(k) + dx.segment<3>(20 + 3 * k);
    EXPECT_LT((state.landmark(k) - p_world).norm(), 1e-14);
  }
}

TEST(FilterState, ApplyCorrectionWithPoseUsesTheExtendedPoseExponential) {
  std::mt19937 rng(6);
  FilterState state = randomState(2, &rng);
  const FilterState before = state;
  const Eigen::VectorXd dx = 0.3 * randomMatrix(state.dim(), 1, &rng);
  state.applyCorrection(dx, true);
  expectAuxiliaryCorrected(state, before, dx);
  const Vector6d eps = dx.head<6>();
  const Eigen::Matrix4d world_T_imu = se3::inverse(before.imu_T_world);
  for (size_t k = 0; k < 2; ++k) {
    // X = [[R, t, p], [0, 1, 0], [0, 0, 1]] moves to exp(dx^) X.
    Eigen::Matrix<double, 5, 5> X = Eigen::Matrix<double, 5, 5>::Identity();
    X.topLeftCorner<3, 4>() = world_T_imu.topRows<3>();
    X.block<3, 1>(0, 4) = before.landmark(k);
    const Eigen::Matrix<double, 5, 5> X_new = extendedExp(eps, dx.segment<3>(20 + 3 * k)) * X;
    EXPECT_LT((se3::inverse(state.imu_T_world) - X_new.topLeftCorner<4, 4>()).norm(), 1e-12);
    EXPECT_LT((state.landmark(k) - X_new.block<3, 1>(0, 4)).norm(), 1e-12) << "landmark " << k;
  }
}

TEST(FilterState, ApplyCorrectionInInverseDepthMovesLandmarksAlongTheirInverseDepthLines) {
  // The same correction as the Cartesian one seen from the pose (the pose itself unchanged),
  // except that each landmark in front of the camera lands on inverse_depth_retraction::move of
  // the Cartesian move; one behind the camera moves as before.
  std::mt19937 rng(7);
  FilterState cartesian = randomState(0, &rng);
  Eigen::Matrix4d cam_T_imu = Eigen::Matrix4d::Identity();
  cam_T_imu.topLeftCorner<3, 3>() << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // x forward -> z forward
  cam_T_imu.topRightCorner<3, 1>() << 0.1, -0.05, 0.3;
  const Eigen::Matrix4d cam_T_world = cam_T_imu * cartesian.imu_T_world;
  const Eigen::Matrix4d world_T_cam = se3::inverse(cam_T_world);
  const std::vector<Eigen::Vector3d> points_cam = {
      {2.0, -1.0, 5.0}, {-4.0, 1.0, 25.0}, {6.0, 0.5, 70.0}, {1.0, 0.0, -8.0}};
  for (const Eigen::Vector3d& q : points_cam) {
    cartesian.appendLandmark((world_T_cam * q.homogeneous()).head<3>(),
                             Eigen::MatrixXd::Zero(3, cartesian.dim()),
                             Eigen::Matrix3d::Identity());
  }
  FilterState inverse_depth = cartesian;
  inverse_depth.inverse_depth_cam_T_imu = cam_T_imu;
  Eigen::VectorXd dx = 0.05 * randomMatrix(cartesian.dim(), 1, &rng);
  dx.tail(3 * points_cam.size()) *= 40.0;  // metres of landmark correction
  cartesian.applyCorrection(dx, true);
  inverse_depth.applyCorrection(dx, true);
  EXPECT_TRUE(inverse_depth.imu_T_world == cartesian.imu_T_world);
  const Eigen::Matrix4d cam_T_world_after = cam_T_imu * cartesian.imu_T_world;
  for (size_t k = 0; k < points_cam.size(); ++k) {
    const Eigen::Vector3d q_cartesian =
        (cam_T_world_after * cartesian.landmark(k).homogeneous()).head<3>();
    const Eigen::Vector3d q_moved =
        (cam_T_world_after * inverse_depth.landmark(k).homogeneous()).head<3>();
    const Eigen::Vector3d expected =
        inverse_depth_retraction::move(points_cam[k], q_cartesian - points_cam[k]);
    EXPECT_LT((q_moved - expected).norm(), 1e-9) << "landmark " << k;
    if (k < 3) {
      EXPECT_GT((q_moved - q_cartesian).norm(), 1e-3) << "landmark " << k;
    }
  }
}

// One twist step applied at once: F S F^T + D Q D^T + diag(r), F = I + D G A (the
// propagator's map before deferral), on both covariances.
void applyStepNow(FilterState* state, const Eigen::MatrixXd& G, const Matrix6d& Q,
                  const Eigen::VectorXd& r) {
  const int dim = state->dim(), aux = state->layout().auxDim();
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(dim, 6);
  D.topLeftCorner<6, 6>().setIdentity();
  for (size_t k = 0; k < state->landmarkCount(); ++k) {
    D.block<3, 3>(state->layout().landmarkRow(k), 3) = se3::hat(state->landmark(k));
  }
  Eigen::MatrixXd F = Eigen::MatrixXd::Identity(dim, dim);
  F.middleCols(6, aux) += D * G;
  for (int which = 0; which < state->covarianceCount(); ++which) {
    auto S = state->covariance(which);
    const Eigen::MatrixXd next = F * S * F.transpose() + D * Q * D.transpose();
    S = next;
    S.block(6, 6, aux, aux).diagonal() += r;
  }
}

TEST(FilterState, DeferredPredictionsComposeExactlyIntoTheStepByStepCovariance) {
  std::mt19937 rng(7);
  StateLayout layout = fullLayout();
  layout.tilt_dim = 2;
  layout.reported_covariance = true;
  FilterState deferred(layout);
  deferred.reset(testPrior());
  for (int k = 0; k < 5; ++k) {
    deferred.appendLandmark(10.0 * randomMatrix(3, 1, &rng),
                            Eigen::MatrixXd::Zero(3, deferred.dim()), Eigen::Matrix3d::Identity());
  }
  const Eigen::MatrixXd A = randomMatrix(deferred.dim(), deferred.dim(), &rng);
  deferred.covariance(0) = A * A.transpose();
  deferred.covariance(1) =
      2.0 * A * A.transpose() + Eigen::MatrixXd::Identity(deferred.dim(), deferred.dim());
  FilterState stepwise = deferred;
  const int aux = layout.auxDim();
  for (int step = 0; step < 7; ++step) {
    Eigen::MatrixXd G = 0.1 * randomMatrix(6, aux, &rng);
    G.rightCols(2).setZero();  // no twist depends on the road tilt
    const Eigen::MatrixXd B = 0.1 * randomMatrix(6, 6, &rng);
    const Matrix6d Q = B * B.transpose();
    Eigen::VectorXd r = 0.01 * randomMatrix(aux, 1, &rng).cwiseAbs();
    r.tail(2).setZero();
    deferred.deferPrediction(G, Q, r, true);
    applyStepNow(&stepwise, G, Q, r);
    // The road tilt's step between twists, on the deferred state's stale covariance.
    deferred.propagateRoadTiltCovariance(0.9, 0.003);
    stepwise.propagateRoadTiltCovariance(0.9, 0.003);
    // The blocks read at twist rate, without applying anything.
    for (int which = 0; which < 2; ++which) {
      EXPECT_LT((deferred.poseCovariance(which) - stepwise.covariance(which).topLeftCorner<6, 6>())
                    .norm(),
                1e-10 * stepwise.covariance(which).norm())
          << "step " << step;
      EXPECT_LT(
          (deferred.auxCovariance(which) - stepwise.covariance(which).block(6, 6, aux, aux)).norm(),
          1e-10 * stepwise.covariance(which).norm());
    }
  }
  for (int which = 0; which < 2; ++which) {
    const Eigen::MatrixXd expected = stepwise.covariance(which);
    EXPECT_LT((deferred.covariance(which) - expected).norm(), 1e-10 * expected.norm());
  }
}

TEST(FilterState, ALandmarkChangeAppliesTheDeferredPredictionsFirst) {
  std::mt19937 rng(8);
  FilterState deferred = randomState(3, &rng);
  FilterState stepwise = deferred;
  const int aux = deferred.layout().auxDim();
  const Eigen::MatrixXd G = 0.1 * randomMatrix(6, aux, &rng);
  const Matrix6d Q = 0.01 * Matrix6d::Identity();
  const Eigen::VectorXd r = Eigen::VectorXd::Zero(aux);
  deferred.deferPrediction(G, Q, r, true);
  applyStepNow(&stepwise, G, Q, r);
  // D holds the landmark means: moving one must not change what the earlier step does.
  deferred.setLandmark(0, Eigen::Vector3d(1, 2, 3));
  stepwise.setLandmark(0, Eigen::Vector3d(1, 2, 3));
  EXPECT_LT((deferred.covariance() - stepwise.covariance()).norm(),
            1e-12 * stepwise.covariance().norm());
}

TEST(FilterState, ProcessNoiseSinceTheUpdateIsSummedAndCanBeWidened) {
  std::mt19937 rng(9);
  FilterState state = randomState(3, &rng);
  FilterState expected = state;
  const int aux = state.layout().auxDim();
  const Eigen::MatrixXd G = 0.1 * randomMatrix(6, aux, &rng);
  const Eigen::MatrixXd B = 0.1 * randomMatrix(6, 6, &rng);
  const Matrix6d Q = B * B.transpose();
  const Eigen::VectorXd r = Eigen::VectorXd::Zero(aux);
  state.deferPrediction(G, Q, r, true);
  state.deferPrediction(G, 2.0 * Q, r, true);
  EXPECT_LT((state.processNoiseSinceUpdate() - 3.0 * Q).norm(), 1e-15);
  // Widening: the same D Q D^T as a step with F = I, in every covariance, the means unchanged.
  state.addPoseProcessNoise(5.0 * Q, true);
  applyStepNow(&expected, G, Q, r);
  applyStepNow(&expected, G, 2.0 * Q, r);
  applyStepNow(&expected, Eigen::MatrixXd::Zero(6, aux), 5.0 * Q, r);
  for (int which = 0; which < state.covarianceCount(); ++which) {
    EXPECT_LT((state.covariance(which) - expected.covariance(which)).norm(),
              1e-10 * expected.covariance(which).norm());
  }
  EXPECT_TRUE(state.imu_T_world.isApprox(expected.imu_T_world));
  state.markUpdate();
  EXPECT_TRUE(state.processNoiseSinceUpdate().isZero(0.0));
}

}  // namespace
}  // namespace ekf_vislam
