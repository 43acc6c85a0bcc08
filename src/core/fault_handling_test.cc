// Fault matrix of the estimator core: every kind of bad input and every filter fault the core
// detects, fed into a VislamEstimator in the middle of a synthetic drive. For each case:
//   - the right Counter moves by exactly the number of faults injected (observation faults are
//     compared with a twin estimator fed the clean message from the same state, so the natural
//     rejections of the frame cancel);
//   - the FeedResult says what happened (accepted = false and a message for a rejected message);
//   - the filter is not corrupted: pose, pose covariance and state covariance finite, the
//     covariance symmetric and positive semi-definite, every landmark of the map finite; a
//     rejected message leaves the state exactly as it was;
//   - the filter keeps working: the rest of the drive ends within 2x (+0.1 m) of the final
//     position error of the same drive without the fault, or, for faults that end every track
//     (empty frame, resets, divergence recoveries), its motion from the first frame after the
//     fault is within 2x (+0.1 m) of the clean drive's over the same frames (see Check).
#include "ekf_vislam/core/vislam_estimator.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/stereo_camera.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace ekf_vislam {
namespace {

using testing::makeScenario;
using testing::Scenario;
using testing::ScenarioOptions;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr size_t kFrames = 300;  ///< length of the drive
constexpr size_t kFault = 150;   ///< frame at which the fault is injected

const Scenario& drive() {
  static const Scenario scenario = [] {
    ScenarioOptions so;
    so.frames = static_cast<int>(kFrames);
    so.seed = 7;
    return makeScenario(so);
  }();
  return scenario;
}

// Noise matched to the scenario.
VislamOptions faultOptions() { return testing::matchedOptions(testing::ScenarioOptions()); }

/// Counter increments of `after` over `before`.
int64_t delta(const EstimatorStats& before, const EstimatorStats& after, Counter c) {
  return static_cast<int64_t>(after.get(c)) - static_cast<int64_t>(before.get(c));
}

/// The filter is not corrupted: everything finite, covariance symmetric and PSD, map finite.
void expectHealthy(const VislamEstimator& e, const std::string& where) {
  SCOPED_TRACE(where);
  EXPECT_TRUE(e.worldTImu().matrix().allFinite());
  EXPECT_TRUE(e.poseCovarianceWorld().allFinite());
  const Eigen::MatrixXd S = e.stateCovariance();
  ASSERT_EQ(S.rows(), e.stateDimension());
  ASSERT_TRUE(S.allFinite());
  const double norm = S.norm();
  EXPECT_LE((S - S.transpose()).norm(), 1e-9 * norm) << "covariance not symmetric";
  if (S.rows() <= 1000) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S, Eigen::EigenvaluesOnly);
    ASSERT_EQ(eig.info(), Eigen::Success);
    const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
    EXPECT_GE(lo, -1e-9 * hi) << "covariance not positive semi-definite";
  } else {
    // Large states (the 10000-feature frame): S + 1e-9 bound(max eigenvalue) I must have a
    // Cholesky factor (the eigen decomposition would take half a minute).
    const double bound = S.cwiseAbs().rowwise().sum().maxCoeff();  // >= max eigenvalue
    Eigen::MatrixXd shifted = S;
    shifted.diagonal().array() += 1e-9 * bound;
    EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(shifted).info(), Eigen::Success)
        << "covariance not positive semi-definite";
  }
  size_t bad = 0;
  for (const LandmarkEstimate& l : e.landmarks()) {
    bad += !(l.p_world.allFinite() && l.covariance.allFinite());
  }
  EXPECT_EQ(bad, 0u) << "landmarks with non-finite estimate";
}

/// A rejected message must leave the state exactly as it was.
struct Snapshot {
  explicit Snapshot(const VislamEstimator& e)
      : pose(e.worldTImu().matrix()),
        covariance(e.stateCovariance()),
        time(e.time()),
        map_size(e.landmarks().size()),
        active(e.activeLandmarkCount()) {}
  void expectUnchanged(const VislamEstimator& e) const {
    EXPECT_EQ(pose, e.worldTImu().matrix());
    EXPECT_EQ(covariance, e.stateCovariance());
    EXPECT_EQ(time, e.time());
    EXPECT_EQ(map_size, e.landmarks().size());
    EXPECT_EQ(active, e.activeLandmarkCount());
  }
  Eigen::Matrix4d pose;
  Eigen::MatrixXd covariance;
  double time;
  size_t map_size, active;
};

double positionError(const VislamEstimator& e, size_t k) {
  return (e.worldTImu().translation() - drive().world_T_imu[k].topRightCorner<3, 1>()).norm();
}

/// Feeds twist and frame k of the drive (both must be used).
void step(VislamEstimator* e, size_t k) {
  const FeedResult t = e->feedTwist(drive().twists[k]);
  ASSERT_TRUE(t.accepted) << "twist " << k << ": " << t.message;
  const FeedResult f = e->feedFeatures(drive().frames[k]);
  ASSERT_TRUE(f.accepted) << "frame " << k << ": " << f.message;
}

void runFrames(VislamEstimator* e, size_t from, size_t to) {
  for (size_t k = from; k < to; ++k) step(e, k);
}

/// Estimated world_T_imu at every frame of the whole drive without faults, for these options.
std::vector<Eigen::Matrix4d> cleanPoses(const VislamOptions& o) {
  VislamEstimator e(o);
  EXPECT_TRUE(e.setCalibration(drive().calibration));
  std::vector<Eigen::Matrix4d> poses;
  for (size_t k = 0; k < kFrames; ++k) {
    step(&e, k);
    poses.push_back(e.worldTImu().matrix());
  }
  return poses;
}

/// Position error of the estimated motion from frame j to frame k (in the IMU frame at j).
double motionError(const Eigen::Matrix4d& est_j, const Eigen::Matrix4d& est_k, size_t j, size_t k) {
  const Eigen::Matrix4d est = se3::inverse(est_j) * est_k;
  const Eigen::Matrix4d truth = se3::inverse(drive().world_T_imu[j]) * drive().world_T_imu[k];
  return (est.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm();
}

enum class Check {
  /// The final position error must stay within 2x (+0.1 m) of the clean drive's: faults that
  /// must not cost accuracy.
  kFinalError,
  /// Faults that end every track (empty frame, recoveries, resets) cost accuracy by design: the
  /// frames without a tracked landmark are dead reckoning and the heading error they add stays
  /// (it is unobservable). What must hold is that the filter works as before once it tracks again:
  /// the motion from the first frame after the fault to the end must be within 2x (+0.1 m) of the
  /// clean drive's over the same frames.
  kMotionAfterRestart,
};

/// The drive's final position error within 2x a reference run's (named in the print) + 0.1 m.
void expectFinalErrorNear(const VislamEstimator& e, double reference_error,
                          const std::string& reference) {
  const double error = positionError(e, kFrames - 1);
  std::printf("    final position error %.3f m (%s %.3f m)\n", error, reference.c_str(),
              reference_error);
  EXPECT_LE(error, 2.0 * reference_error + 0.1);
}

/// Continues the drive from frame `from` to the end and checks the result (see Check).
void expectRecovers(VislamEstimator* e, size_t from, const VislamOptions& o,
                    Check check = Check::kFinalError) {
  const std::vector<Eigen::Matrix4d> clean = cleanPoses(o);
  const size_t last = kFrames - 1;
  if (check == Check::kFinalError) {
    runFrames(e, from, kFrames);
    expectHealthy(*e, "end of the drive");
    expectFinalErrorNear(
        *e,
        (clean[last].topRightCorner<3, 1>() - drive().world_T_imu[last].topRightCorner<3, 1>())
            .norm(),
        "clean drive");
    return;
  }
  step(e, from);
  const Eigen::Matrix4d start = e->worldTImu().matrix();
  runFrames(e, from + 1, kFrames);
  expectHealthy(*e, "end of the drive");
  const double reference = motionError(clean[from], clean[last], from, last);
  const double error = motionError(start, e->worldTImu().matrix(), from, last);
  std::printf(
      "    motion error over frames %zu-%zu %.3f m (clean drive %.3f m); final position "
      "error %.3f m (clean %.3f m)\n",
      from, last, error, reference, positionError(*e, last),
      (clean[last].topRightCorner<3, 1>() - drive().world_T_imu[last].topRightCorner<3, 1>())
          .norm());
  EXPECT_LE(error, 2.0 * reference + 0.1);
}

/// An estimator that has driven frames [0, kFault).
VislamEstimator startedEstimator(const VislamOptions& o = faultOptions()) {
  VislamEstimator e(o);
  EXPECT_TRUE(e.setCalibration(drive().calibration));
  runFrames(&e, 0, kFault);
  return e;
}

/// Feeds `faulty` to e and `clean` to a copy of e made before; returns the counter increments
/// of e beyond those of the copy (what the fault added) and the two results.
struct TwinResult {
  FeedResult faulty, clean;
  EstimatorStats before, after_faulty, after_clean;
  int64_t extra(Counter c) const {
    return delta(before, after_faulty, c) - delta(before, after_clean, c);
  }
};

TwinResult feedTwin(VislamEstimator* e, const FeatureFrame& faulty, const FeatureFrame& clean) {
  VislamEstimator twin = *e;
  TwinResult r;
  r.before = e->stats();
  r.clean = twin.feedFeatures(clean);
  r.faulty = e->feedFeatures(faulty);
  r.after_faulty = e->stats();
  r.after_clean = twin.stats();
  return r;
}

/// Observation-level fault counters: an injected fault must move exactly its own counter.
const Counter kObservationFaults[] = {
    Counter::kObsNonFinite,       Counter::kObsDisparity,    Counter::kObsDepth,
    Counter::kObsOutsideImage,    Counter::kObsRowMismatch,  Counter::kObsDuplicateId,
    Counter::kDivergenceRecovery, Counter::kUpdateNonFinite, Counter::kCovarianceRepaired};

void expectOnlyObservationFault(const TwinResult& r, Counter counter, int64_t count) {
  for (Counter c : kObservationFaults) {
    EXPECT_EQ(r.extra(c), c == counter ? count : 0) << counterName(c);
  }
  EXPECT_TRUE(r.faulty.accepted) << r.faulty.message;
  EXPECT_GE(r.faulty.observations_rejected, static_cast<int>(count));
}

/// Indices (into frame.features) of `n` features of frame k whose id was tracked at frame k-1.
std::vector<size_t> trackedFeatures(size_t k, size_t n) {
  std::vector<size_t> out;
  const FeatureFrame& prev = drive().frames[k - 1];
  const FeatureFrame& frame = drive().frames[k];
  for (size_t i = 0; i < frame.features.size() && out.size() < n; ++i) {
    for (const StereoObservation& p : prev.features) {
      if (p.id == frame.features[i].id) {
        out.push_back(i);
        break;
      }
    }
  }
  EXPECT_EQ(out.size(), n);
  return out;
}

TwistData twistAt(size_t k) { return drive().twists[k]; }

// ---------------------------------------------------------------------------------------------
// Twist faults
// ---------------------------------------------------------------------------------------------

TEST(FaultHandling, TwistNonFiniteIsRejectedAndChangesNothing) {
  VislamEstimator e = startedEstimator();
  std::vector<TwistData> faults(4, twistAt(kFault));
  faults[0].v_imu.x() = kNaN;
  faults[1].w_imu.z() = kInf;
  faults[2].v_imu.y() = -kInf;
  faults[3].stamp = kNaN;
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  for (const TwistData& t : faults) {
    const FeedResult r = e.feedTwist(t);
    EXPECT_FALSE(r.accepted);
    EXPECT_FALSE(r.message.empty());
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistNonFinite), 4);
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistUsed), 0);
  snapshot.expectUnchanged(e);
  expectHealthy(e, "after the faults");
  expectRecovers(&e, kFault, faultOptions());
}

TEST(FaultHandling, TwistImplausibleMagnitudeIsRejected) {
  VislamEstimator e = startedEstimator();
  const VislamOptions o = faultOptions();
  TwistData fast = twistAt(kFault), spin = twistAt(kFault);
  fast.v_imu = Eigen::Vector3d(1.5 * o.limits.max_linear_speed, 0.0, 0.0);
  spin.w_imu = Eigen::Vector3d(0.0, 0.0, -1.5 * o.limits.max_angular_speed);
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  for (const TwistData& t : {fast, spin}) {
    const FeedResult r = e.feedTwist(t);
    EXPECT_FALSE(r.accepted);
    EXPECT_NE(r.message.find("max_"), std::string::npos) << r.message;
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistImplausible), 2);
  snapshot.expectUnchanged(e);
  expectRecovers(&e, kFault, o);
}

TEST(FaultHandling, AccelerometerFaultsAreRejectedAndChangeNothing) {
  // Non-finite samples, a message without an accelerometer (all zero) or in other units, and a
  // sample older than the twists already integrated: each rejected and counted, the filter as it
  // was (no gravity rows are added for samples that are not used).
  VislamEstimator e = startedEstimator();
  const double stamp = twistAt(kFault).stamp;
  std::vector<AccelerometerData> bad(5);
  for (AccelerometerData& a : bad) {
    a.stamp = stamp + 0.05;
    a.f_imu = Eigen::Vector3d(0.0, 0.0, 9.8);
  }
  bad[0].f_imu.x() = kNaN;
  bad[1].stamp = kNaN;
  bad[2].covariance(1, 1) = kInf;
  bad[3].f_imu.setZero();                               // a gyro-only Imu read as one
  bad[4].f_imu = Eigen::Vector3d(0.0, 0.0, 9.8 * 9.8);  // not m/s^2
  const Snapshot snapshot(e);
  const int dim = e.stateDimension();
  const EstimatorStats before = e.stats();
  for (const AccelerometerData& a : bad) {
    const FeedResult r = e.feedAccelerometer(a);
    EXPECT_FALSE(r.accepted);
    EXPECT_FALSE(r.message.empty());
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kAccelNonFinite), 3);
  EXPECT_EQ(delta(before, e.stats(), Counter::kAccelImplausible), 2);
  EXPECT_EQ(delta(before, e.stats(), Counter::kAccelUsed), 0);
  EXPECT_EQ(e.stateDimension(), dim);
  snapshot.expectUnchanged(e);
  // A good sample is taken; one older than it is late; the gravity rows join the state when the
  // first window opens, a window length (1 s) after the first sample.
  AccelerometerData good;
  good.stamp = stamp - 0.05;  // in the period of the next twist
  good.f_imu = Eigen::Vector3d(0.0, 0.0, 9.8);
  EXPECT_TRUE(e.feedAccelerometer(good).accepted);
  good.stamp -= 0.01;
  EXPECT_FALSE(e.feedAccelerometer(good).accepted);
  EXPECT_EQ(delta(before, e.stats(), Counter::kAccelLate), 1);
  EXPECT_EQ(e.stateDimension(), dim);
  for (size_t k = kFault; k < kFault + 12; ++k) EXPECT_TRUE(e.feedTwist(twistAt(k)).accepted);
  EXPECT_EQ(e.stateDimension(), dim + 5);
  expectHealthy(e, "after the faults");
}

TEST(FaultHandling, TwistDuplicateStampIsRejected) {
  VislamEstimator e = startedEstimator();
  ASSERT_TRUE(e.feedTwist(twistAt(kFault)).accepted);
  TwistData again = twistAt(kFault);
  again.v_imu *= 2.0;  // a different value at the same stamp: zero dt
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  const FeedResult r = e.feedTwist(again);
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.message.find("duplicate"), std::string::npos) << r.message;
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistNotIncreasing), 1);
  snapshot.expectUnchanged(e);
  ASSERT_TRUE(e.feedFeatures(drive().frames[kFault]).accepted);
  expectHealthy(e, "after the duplicate");
  expectRecovers(&e, kFault + 1, faultOptions());
}

TEST(FaultHandling, TwistTimeGoingBackwardsIsRejected) {
  VislamEstimator e = startedEstimator();
  step(&e, kFault);
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  for (double back : {0.05, 0.1, 3.0, 1e6}) {
    TwistData old = twistAt(kFault);
    old.stamp -= back;
    const FeedResult r = e.feedTwist(old);
    EXPECT_FALSE(r.accepted);
    EXPECT_NE(r.message.find("backwards"), std::string::npos) << r.message;
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistNotIncreasing), 4);
  snapshot.expectUnchanged(e);
  expectRecovers(&e, kFault + 1, faultOptions());
}

TEST(FaultHandling, TwistOlderThanTheFilterTimeIsHeldWithoutPrediction) {
  // The frame of t_k arrives before the twist of t_k (late twist, after the previous twist):
  // held for the next interval, no prediction backwards.
  VislamEstimator e = startedEstimator();
  ASSERT_TRUE(e.feedFeatures(drive().frames[kFault]).accepted);  // predicted with twist k-1
  TwistData late = twistAt(kFault);
  late.stamp -= 0.02;
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  const FeedResult r = e.feedTwist(late);
  EXPECT_TRUE(r.accepted);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistLate), 1);
  snapshot.expectUnchanged(e);
  expectHealthy(e, "after the late twist");
  expectRecovers(&e, kFault + 1, faultOptions());
}

// A gap of 1.5 s with neither twists nor frames (e.g. the driver restarted).
constexpr size_t kGapFrames = 15;

TEST(FaultHandling, TwistGapBeyondMaxTwistGapPredictPolicy) {
  VislamOptions o = faultOptions();
  o.limits.gap_policy = GapPolicy::kPredict;
  // The heading error that 1.5 s of prediction on a held twist adds is unobservable and stays, so
  // what must hold is that the filter works as before once the twist returns (the motion after
  // the gap against the clean drive's, as for the faults that end every track).
  VislamEstimator e = startedEstimator(o);
  const size_t resume = kFault + kGapFrames;
  ASSERT_GT(twistAt(resume).stamp - twistAt(kFault - 1).stamp, o.limits.max_twist_gap);
  const EstimatorStats before = e.stats();
  const FeedResult r = e.feedTwist(twistAt(resume));
  EXPECT_TRUE(r.accepted);
  EXPECT_NE(r.message.find("max_twist_gap"), std::string::npos) << r.message;
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistGap), 1);
  EXPECT_EQ(e.time(), twistAt(resume).stamp);
  expectHealthy(e, "after the gap");
  ASSERT_TRUE(e.feedFeatures(drive().frames[resume]).accepted);
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistGap), 1);
  expectHealthy(e, "first frame after the gap");
  expectRecovers(&e, resume + 1, o, Check::kMotionAfterRestart);
}

TEST(FaultHandling, TwistGapBeyondMaxTwistGapResetPolicy) {
  VislamOptions o = faultOptions();
  o.limits.gap_policy = GapPolicy::kReset;
  VislamEstimator e = startedEstimator(o);
  const size_t resume = kFault + kGapFrames;
  const size_t map_before = e.landmarks().size();
  std::vector<LandmarkEstimate> old_map = e.landmarks();
  const EstimatorStats before = e.stats();
  const FeedResult r = e.feedTwist(twistAt(resume));
  EXPECT_TRUE(r.accepted);
  EXPECT_NE(r.message.find("reset"), std::string::npos) << r.message;
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistGap), 1);
  // Pose restarts at the identity, the map is kept (every landmark now inactive, same estimate).
  EXPECT_TRUE(e.worldTImu().matrix().isIdentity(0.0));
  EXPECT_EQ(e.activeLandmarkCount(), 0u);
  ASSERT_EQ(e.landmarks().size(), map_before);
  for (size_t i = 0; i < map_before; ++i) {
    EXPECT_FALSE(e.landmarks()[i].active);
    EXPECT_EQ(e.landmarks()[i].p_world, old_map[i].p_world);
  }
  expectHealthy(e, "after the reset");
  ASSERT_TRUE(e.feedFeatures(drive().frames[resume]).accepted);
  expectHealthy(e, "first frame after the reset");
  // The new world frame is the IMU frame at the reset: only the motion since then can be checked.
  expectRecovers(&e, resume + 1, o, Check::kMotionAfterRestart);
}

TEST(FaultHandling, TwistStreamStoppingWhileFramesContinueIsAGap) {
  // Twists stop for 1.5 s but feature frames keep coming: the filter predicts each frame with
  // the last twist it got. That is a twist gap (limits/max_twist_gap: "What to do when twist
  // messages stop for longer than limits/max_twist_gap"), whatever else arrives meanwhile.
  VislamOptions o = faultOptions();
  VislamEstimator e = startedEstimator(o);
  const EstimatorStats before = e.stats();
  for (size_t k = kFault; k < kFault + kGapFrames; ++k) {
    const FeedResult r = e.feedFeatures(drive().frames[k]);
    EXPECT_TRUE(r.accepted);
  }
  expectHealthy(e, "frames without twists");
  const FeedResult r = e.feedTwist(twistAt(kFault + kGapFrames));
  EXPECT_TRUE(r.accepted);
  EXPECT_EQ(delta(before, e.stats(), Counter::kTwistGap), 1)
      << "1.5 s without any twist (max_twist_gap " << o.limits.max_twist_gap << " s) not counted";
  ASSERT_TRUE(e.feedFeatures(drive().frames[kFault + kGapFrames]).accepted);
  expectRecovers(&e, kFault + kGapFrames + 1, o);
}

// ---------------------------------------------------------------------------------------------
// Observation faults (one frame of the drive with some features broken)
// ---------------------------------------------------------------------------------------------

class ObservationFault : public ::testing::Test {
 protected:
  void SetUp() override {
    e_ = std::make_unique<VislamEstimator>(startedEstimator());
    ASSERT_TRUE(e_->feedTwist(twistAt(kFault)).accepted);
    clean_ = drive().frames[kFault];
    faulty_ = clean_;
  }
  TwinResult feed() {
    const TwinResult r = feedTwin(e_.get(), faulty_, clean_);
    expectHealthy(*e_, "after the faulty frame");
    return r;
  }
  void finish(Check check = Check::kFinalError) {
    expectRecovers(e_.get(), kFault + 1, faultOptions(), check);
  }

  std::unique_ptr<VislamEstimator> e_;
  FeatureFrame clean_, faulty_;
};

TEST_F(ObservationFault, NonFiniteCoordinates) {
  const std::vector<size_t> idx = trackedFeatures(kFault, 4);
  faulty_.features[idx[0]].u_left = kNaN;
  faulty_.features[idx[1]].v_right = kInf;
  faulty_.features[idx[2]].u_right = -kInf;
  faulty_.features[idx[3]].v_left = kNaN;
  faulty_.features[idx[3]].u_left = kInf;
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsNonFinite, 4);
  // The ids stay tracked (a bad measurement does not end a track).
  EXPECT_EQ(r.faulty.landmarks_marginalized, r.clean.landmarks_marginalized);
  finish();
}

TEST_F(ObservationFault, ZeroAndNegativeDisparity) {
  const std::vector<size_t> idx = trackedFeatures(kFault, 3);
  StereoObservation& zero = faulty_.features[idx[0]];
  zero.u_right = zero.u_left;
  StereoObservation& negative = faulty_.features[idx[1]];
  std::swap(negative.u_left, negative.u_right);
  StereoObservation& tiny = faulty_.features[idx[2]];
  tiny.u_right = tiny.u_left - 0.5 * faultOptions().landmarks.min_disparity_px;
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsDisparity, 3);
  finish();
}

TEST_F(ObservationFault, TooFarForTheDepthRange) {
  // A new id whose disparity gives a depth beyond landmarks/max_depth: not initialized.
  StereoObservation far;
  far.id = 900000;
  far.u_left = 600.0;
  far.v_left = far.v_right = 200.0;
  const StereoCalibration& c = drive().calibration;
  far.u_right = far.u_left - c.fx * c.baseline / (3.0 * faultOptions().landmarks.max_depth);
  faulty_.features.push_back(far);
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsDepth, 1);
  finish();
}

TEST_F(ObservationFault, CoordinatesOutsideTheImage) {
  const std::vector<size_t> idx = trackedFeatures(kFault, 4);
  const StereoCalibration& c = drive().calibration;
  faulty_.features[idx[0]].u_left = -40.0;
  faulty_.features[idx[1]].v_left = faulty_.features[idx[1]].v_right = c.image_height + 50.0;
  faulty_.features[idx[2]].u_right = c.image_width + 10.0;
  faulty_.features[idx[3]].u_left = 1e12;
  faulty_.features[idx[3]].u_right = -1e12;
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsOutsideImage, 4);
  finish();
}

TEST_F(ObservationFault, LeftAndRightRowsDisagree) {
  const std::vector<size_t> idx = trackedFeatures(kFault, 2);
  const double limit = faultOptions().limits.max_row_difference_px;
  for (size_t i : idx) {
    StereoObservation& f = faulty_.features[i];
    // Move the right row towards the image centre so it stays inside the image.
    f.v_right = f.v_left + (f.v_left < 188.0 ? 1.0 : -1.0) * (limit + 20.0);
  }
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsRowMismatch, 2);
  finish();
}

TEST_F(ObservationFault, DuplicateIdsInOneMessage) {
  // Three extra copies of two ids (conflicting coordinates): all but the first are dropped.
  const std::vector<size_t> idx = trackedFeatures(kFault, 2);
  for (int copy = 0; copy < 2; ++copy) {
    StereoObservation f = clean_.features[idx[0]];
    f.u_left += 30.0 * (copy + 1);
    f.u_right += 30.0 * (copy + 1);
    faulty_.features.push_back(f);
  }
  faulty_.features.push_back(clean_.features[idx[1]]);  // an exact repeat
  const TwinResult r = feed();
  expectOnlyObservationFault(r, Counter::kObsDuplicateId, 3);
  // The first occurrence is used exactly as in the clean frame.
  EXPECT_EQ(r.faulty.observations_updated, r.clean.observations_updated);
  EXPECT_EQ(r.faulty.landmarks_initialized, r.clean.landmarks_initialized);
  finish();
}

TEST_F(ObservationFault, IdReappearingAfterItsTrackEndedIsANewLandmark) {
  // An id whose track ended some frames ago comes back: a new map entry; the old entry (final
  // estimate of the ended track) stays exactly as it was.
  std::vector<uint32_t> now;
  for (const StereoObservation& f : clean_.features) now.push_back(f.id);
  auto present = [](const FeatureFrame& frame, uint32_t id) {
    for (const StereoObservation& f : frame.features) {
      if (f.id == id) return true;
    }
    return false;
  };
  const StereoCamera camera(drive().calibration);
  const Eigen::Matrix4d imu_T_world = se3::inverse(drive().world_T_imu[kFault]);
  bool found = false;
  StereoObservation back;
  for (size_t k = kFault - 5; k > kFault - 40 && !found; --k) {
    for (const StereoObservation& f : drive().frames[k].features) {
      if (present(drive().frames[k + 1], f.id) || present(clean_, f.id)) continue;
      Eigen::Vector4d z;
      if (!camera.project(imu_T_world, drive().p_world.at(f.id), &z, nullptr, nullptr, 2.0) ||
          !camera.inImage(z(0), z(1)) || !camera.inImage(z(2), z(3)) || z(0) - z(2) < 2.0) {
        continue;
      }
      back.id = f.id;
      back.u_left = z(0);
      back.v_left = z(1);
      back.u_right = z(2);
      back.v_right = z(3);
      found = true;
      break;
    }
  }
  ASSERT_TRUE(found) << "no ended track whose landmark is still visible";
  size_t old_index = e_->landmarks().size();
  for (size_t i = 0; i < e_->landmarks().size(); ++i) {
    if (e_->landmarks()[i].id == back.id) old_index = i;
  }
  ASSERT_LT(old_index, e_->landmarks().size());
  const LandmarkEstimate old = e_->landmarks()[old_index];
  ASSERT_FALSE(old.active);
  const size_t map_before = e_->landmarks().size();
  // Entries with this id so far (a track restarted by the jump test has more than one).
  size_t entries_before = 0;
  for (const LandmarkEstimate& l : e_->landmarks()) entries_before += l.id == back.id ? 1 : 0;
  faulty_.features.push_back(back);
  const TwinResult r = feed();
  EXPECT_EQ(r.extra(Counter::kLandmarkInitialized), 1);
  EXPECT_EQ(r.faulty.landmarks_initialized, r.clean.landmarks_initialized + 1);
  EXPECT_EQ(e_->landmarks().size(),
            map_before + static_cast<size_t>(r.faulty.landmarks_initialized));
  size_t entries = 0;
  const LandmarkEstimate* fresh = nullptr;
  for (const LandmarkEstimate& l : e_->landmarks()) {
    if (l.id != back.id) continue;
    ++entries;
    if (&l != &e_->landmarks()[old_index]) fresh = &l;
  }
  EXPECT_EQ(entries, entries_before + 1);
  const LandmarkEstimate& after = e_->landmarks()[old_index];
  EXPECT_EQ(after.p_world, old.p_world);
  EXPECT_EQ(after.covariance, old.covariance);
  EXPECT_EQ(after.observations, old.observations);
  EXPECT_EQ(after.last_stamp, old.last_stamp);
  EXPECT_FALSE(after.active);
  ASSERT_NE(fresh, nullptr);
  EXPECT_TRUE(fresh->active);
  EXPECT_EQ(fresh->observations, 1u);
  EXPECT_LT((fresh->p_world - drive().p_world.at(back.id)).norm(), 3.0);
  finish();
}

TEST_F(ObservationFault, EmptyMessage) {
  faulty_.features.clear();
  const size_t map_before = e_->landmarks().size();
  const size_t active_before = e_->activeLandmarkCount();
  ASSERT_GT(active_before, 0u);
  const TwinResult r = feed();
  EXPECT_TRUE(r.faulty.accepted);
  EXPECT_EQ(r.extra(Counter::kFrameEmpty), 1);
  EXPECT_EQ(delta(r.before, r.after_faulty, Counter::kFrameUsed), 1);
  // A tracker that lost an image: no track ends, the landmarks stay in the state.
  EXPECT_EQ(e_->activeLandmarkCount(), active_before);
  EXPECT_EQ(delta(r.before, r.after_faulty, Counter::kLandmarkMarginalized), 0);
  EXPECT_EQ(e_->landmarks().size(), map_before);
  EXPECT_EQ(e_->time(), clean_.stamp);
  finish(Check::kMotionAfterRestart);
}

TEST_F(ObservationFault, TenThousandFeaturesAreCappedWithoutStalling) {
  const VislamOptions o = faultOptions();
  ASSERT_GT(o.limits.max_features_per_frame, 0);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(40.0, 1200.0), v(20.0, 350.0), disparity(8.0, 60.0);
  while (faulty_.features.size() < 10000) {
    StereoObservation f;
    f.id = 2000000 + static_cast<uint32_t>(faulty_.features.size());
    f.u_left = u(rng);
    f.u_right = f.u_left - disparity(rng);
    f.v_left = f.v_right = v(rng);
    faulty_.features.push_back(f);
  }
  const size_t active_before = e_->activeLandmarkCount();
  const auto start = std::chrono::steady_clock::now();
  const TwinResult r = feedTwin(e_.get(), faulty_, clean_);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("    10000-feature frame: %.3f s (with the clean twin), state dimension %d\n",
              seconds, e_->stateDimension());
  EXPECT_LT(seconds, 5.0);
  EXPECT_TRUE(r.faulty.accepted);
  EXPECT_EQ(r.extra(Counter::kFrameCapped), 1);
  EXPECT_NE(r.faulty.message.find("max_features_per_frame"), std::string::npos) << r.faulty.message;
  EXPECT_GE(r.faulty.observations_rejected, 10000 - o.limits.max_features_per_frame);
  // The clean features (first in the message) were used as usual.
  EXPECT_EQ(r.faulty.observations_updated, r.clean.observations_updated);
  // Only the first max_features_per_frame features can be in the state, besides the landmarks
  // kept through their gap (landmarks/max_track_gap).
  EXPECT_LE(e_->activeLandmarkCount(),
            static_cast<size_t>(o.limits.max_features_per_frame) + active_before);
  expectHealthy(*e_, "after the 10000-feature frame");
  // The next frames shed the extra landmarks once their gap (landmarks/max_track_gap) is over
  // and run at the usual speed.
  const auto next = std::chrono::steady_clock::now();
  for (int k = 1; k <= o.landmarks.max_track_gap + 1; ++k) step(e_.get(), kFault + k);
  const double next_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - next).count();
  std::printf("    next %d frames: %.3f s, state dimension %d\n", o.landmarks.max_track_gap + 1,
              next_s, e_->stateDimension());
  EXPECT_LT(next_s, 2.0 * (o.landmarks.max_track_gap + 1));
  EXPECT_LT(e_->activeLandmarkCount(), 200u);
  expectRecovers(e_.get(), kFault + o.landmarks.max_track_gap + 2, o);
}

// ---------------------------------------------------------------------------------------------
// Message order and calibration
// ---------------------------------------------------------------------------------------------

TEST(FaultHandling, FeaturesBeforeAnyTwistAreRejected) {
  VislamEstimator e(faultOptions());
  ASSERT_TRUE(e.setCalibration(drive().calibration));
  const EstimatorStats before = e.stats();
  for (size_t k = 0; k < 3; ++k) {
    const FeedResult r = e.feedFeatures(drive().frames[k]);
    EXPECT_FALSE(r.accepted);
    EXPECT_FALSE(r.message.empty());
    EXPECT_EQ(r.observations_rejected, static_cast<int>(drive().frames[k].features.size()));
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kFrameBeforeTwist), 3);
  EXPECT_FALSE(e.initialized());
  EXPECT_TRUE(e.landmarks().empty());
  expectHealthy(e, "after the early frames");
  // The drive starts with twist 3: the filter's time origin, and its world frame.
  expectRecovers(&e, 3, faultOptions(), Check::kMotionAfterRestart);
}

TEST(FaultHandling, FeaturesBeforeCalibrationAreRejectedAndPredictionContinues) {
  VislamEstimator e(faultOptions());
  ASSERT_FALSE(e.hasCalibration());
  const EstimatorStats before = e.stats();
  const size_t uncalibrated = 10;
  for (size_t k = 0; k < uncalibrated; ++k) {
    ASSERT_TRUE(e.feedTwist(twistAt(k)).accepted);
    const FeedResult r = e.feedFeatures(drive().frames[k]);
    EXPECT_FALSE(r.accepted);
    EXPECT_NE(r.message.find("calibration"), std::string::npos) << r.message;
  }
  EXPECT_EQ(delta(before, e.stats(), Counter::kFrameNoCalibration),
            static_cast<int64_t>(uncalibrated));
  EXPECT_EQ(e.time(), twistAt(uncalibrated - 1).stamp);
  EXPECT_GT(e.worldTImu().translation().norm(), 5.0);  // predicted along
  EXPECT_LT(positionError(e, uncalibrated - 1), 1.0);
  EXPECT_TRUE(e.landmarks().empty());
  expectHealthy(e, "before calibration");
  ASSERT_TRUE(e.setCalibration(drive().calibration));
  runFrames(&e, uncalibrated, kFrames);
  expectHealthy(e, "end of the drive");
  // The uncalibrated frames are dead reckoning, and the heading error they add stays (it is
  // unobservable): the reference is the drive whose first frames carry no features.
  VislamEstimator reference(faultOptions());
  ASSERT_TRUE(reference.setCalibration(drive().calibration));
  for (size_t k = 0; k < uncalibrated; ++k) {
    ASSERT_TRUE(reference.feedTwist(twistAt(k)).accepted);
    FeatureFrame empty = drive().frames[k];
    empty.features.clear();
    reference.feedFeatures(empty);
  }
  runFrames(&reference, uncalibrated, kFrames);
  expectFinalErrorNear(e, positionError(reference, kFrames - 1),
                       "features from frame " + std::to_string(uncalibrated) + " on");
}

std::vector<std::pair<StereoCalibration, std::string>> invalidCalibrations() {
  std::vector<std::pair<StereoCalibration, std::string>> out;
  const StereoCalibration good = testing::kittiLikeCalibration();
  StereoCalibration c = good;
  c.fx = 0.0;
  out.emplace_back(c, "focal");
  c = good;
  c.fy = -700.0;
  out.emplace_back(c, "focal");
  c = good;
  c.baseline = -good.baseline;
  out.emplace_back(c, "baseline");
  c = good;
  c.baseline = 0.0;
  out.emplace_back(c, "baseline");
  c = good;
  c.cx = kNaN;
  out.emplace_back(c, "principal point");
  c = good;
  c.cam_T_imu.linear() *= 1.1;  // scaled: not orthonormal
  out.emplace_back(c, "rotation");
  c = good;
  c.cam_T_imu.linear().col(0) *= -1.0;  // a reflection (det -1)
  out.emplace_back(c, "rotation");
  c = good;
  c.cam_T_imu.linear() = Eigen::Matrix3d::Zero();
  out.emplace_back(c, "rotation");
  c = good;
  c.cam_T_imu.translation().x() = kInf;
  out.emplace_back(c, "cam_T_imu");
  c = good;
  c.image_width = -1;
  out.emplace_back(c, "image size");
  return out;
}

TEST(FaultHandling, InvalidCalibrationIsRefusedAndTheOldOneKept) {
  const VislamOptions o = faultOptions();
  VislamEstimator e = startedEstimator(o);
  const StereoCalibration good = e.calibration();
  const EstimatorStats before = e.stats();
  for (const auto& [bad, problem] : invalidCalibrations()) {
    SCOPED_TRACE(problem);
    std::string error;
    EXPECT_FALSE(e.setCalibration(bad, &error));
    EXPECT_NE(error.find(problem), std::string::npos) << error;
    EXPECT_FALSE(e.setCalibration(bad));  // no error pointer: no crash
    EXPECT_TRUE(e.hasCalibration());
    EXPECT_EQ(e.calibration().fx, good.fx);
    EXPECT_EQ(e.calibration().fy, good.fy);
    EXPECT_EQ(e.calibration().baseline, good.baseline);
    EXPECT_EQ(e.calibration().cam_T_imu.matrix(), good.cam_T_imu.matrix());
    EXPECT_EQ(e.calibration().image_width, good.image_width);
  }
  // Refusing a calibration is not a data fault: no counter moves.
  for (int i = 0; i < static_cast<int>(Counter::kCount); ++i) {
    EXPECT_EQ(delta(before, e.stats(), static_cast<Counter>(i)), 0)
        << counterName(static_cast<Counter>(i));
  }
  expectHealthy(e, "after the refused calibrations");
  expectRecovers(&e, kFault, o);
}

TEST(FaultHandling, InvalidFirstCalibrationLeavesTheEstimatorUncalibrated) {
  VislamEstimator e(faultOptions());
  for (const auto& [bad, problem] : invalidCalibrations()) {
    std::string error;
    EXPECT_FALSE(e.setCalibration(bad, &error)) << problem;
    EXPECT_FALSE(e.hasCalibration()) << problem;
  }
  ASSERT_TRUE(e.feedTwist(twistAt(0)).accepted);
  ASSERT_TRUE(e.feedTwist(twistAt(1)).accepted);  // prediction needs no calibration
  const FeedResult r = e.feedFeatures(drive().frames[1]);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(e.stats().get(Counter::kFrameNoCalibration), 1u);
  EXPECT_LT(positionError(e, 1), 0.5);
  expectHealthy(e, "uncalibrated");
}

TEST(FaultHandling, StaleFeatureFrameIsRejected) {
  VislamEstimator e = startedEstimator();
  step(&e, kFault);
  const Snapshot snapshot(e);
  const EstimatorStats before = e.stats();
  FeatureFrame stale = drive().frames[kFault - 1];  // 0.1 s older than the filter time
  FeedResult r = e.feedFeatures(stale);
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.message.find("older"), std::string::npos) << r.message;
  EXPECT_EQ(r.observations_rejected, static_cast<int>(stale.features.size()));
  stale.stamp = drive().frames[kFault].stamp - 1e-6;
  EXPECT_FALSE(e.feedFeatures(stale).accepted);
  EXPECT_EQ(delta(before, e.stats(), Counter::kFrameStale), 2);
  FeatureFrame nan_stamp = drive().frames[kFault];
  nan_stamp.stamp = kNaN;
  r = e.feedFeatures(nan_stamp);
  EXPECT_FALSE(r.accepted);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(delta(before, e.stats(), Counter::kFrameNonFiniteStamp), 1);
  snapshot.expectUnchanged(e);
  expectRecovers(&e, kFault + 1, faultOptions());
}

TEST(FaultHandling, RepeatedFeatureFrameKeepsTheFilterHealthy) {
  // The same frame twice (a republished message): same stamp as the filter time, so it is not
  // stale. Whatever the estimator does with it, the filter must stay healthy.
  VislamEstimator e = startedEstimator();
  step(&e, kFault);
  const FeedResult r = e.feedFeatures(drive().frames[kFault]);
  std::printf("    repeated frame: accepted %d, %d observations used again, message '%s'\n",
              r.accepted, r.observations_updated, r.message.c_str());
  expectHealthy(e, "after the repeated frame");
  expectRecovers(&e, kFault + 1, faultOptions());
}

/// Frame k with 12 points that move with the camera (the back of a car driving ahead at a fixed
/// distance): same pixels, same disparity, every frame.
FeatureFrame withCarAhead(size_t k) {
  FeatureFrame frame = drive().frames[k];
  for (uint32_t i = 0; i < 12; ++i) {
    StereoObservation f;
    f.id = 900000 + i;
    f.u_left = 580.0 + 20.0 * (i % 4);
    f.v_left = f.v_right = 170.0 + 15.0 * (i / 4);
    f.u_right = f.u_left - 25.0;
    frame.features.push_back(f);
  }
  return frame;
}

TEST(FaultHandling, TracksOfPointsMovingWithTheCameraAreDropped) {
  double error[2];
  for (int limit : {0, 2}) {
    VislamOptions o = faultOptions();
    o.landmarks.max_restarts = limit;
    VislamEstimator e = startedEstimator(o);
    const EstimatorStats before = e.stats();
    for (size_t k = kFault; k < kFrames; ++k) {
      ASSERT_TRUE(e.feedTwist(twistAt(k)).accepted);
      ASSERT_TRUE(e.feedFeatures(withCarAhead(k)).accepted);
    }
    expectHealthy(e, "end of the drive");
    error[limit > 0] = positionError(e, kFrames - 1);
    const int64_t dropped = delta(before, e.stats(), Counter::kLandmarkTrackDropped);
    std::printf("    max_restarts %d: %lld tracks dropped, final position error %.3f m\n", limit,
                static_cast<long long>(dropped), error[limit > 0]);
    if (limit == 0) {
      EXPECT_EQ(dropped, 0);
    } else {
      EXPECT_EQ(dropped, 12);  // each car point once: its track never ends
      EXPECT_GT(delta(before, e.stats(), Counter::kObsTrackDropped), 12 * 100);
      EXPECT_EQ(delta(before, e.stats(), Counter::kDivergenceRecovery), 0);
    }
  }
  EXPECT_LT(error[1], error[0]);
}

// ---------------------------------------------------------------------------------------------
// Divergence detection and recovery
// ---------------------------------------------------------------------------------------------

const DivergencePolicy kPolicies[] = {DivergencePolicy::kResetLandmarks,
                                      DivergencePolicy::kResetFilter};
const char* policyName(DivergencePolicy p) {
  return p == DivergencePolicy::kResetLandmarks ? "reset_landmarks" : "reset_filter";
}

/// Frame k with every feature replaced by a random (but well-formed) stereo measurement.
FeatureFrame garbageFrame(size_t k, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(60.0, 1180.0), v(20.0, 350.0), disparity(6.0, 50.0);
  FeatureFrame frame = drive().frames[k];
  for (StereoObservation& f : frame.features) {
    f.u_left = u(*rng);
    f.u_right = f.u_left - disparity(*rng);
    f.v_left = f.v_right = v(*rng);
  }
  return frame;
}

/// Feeds max_rejected_frames frames of garbage from kFault on: the estimator recovers once.
void feedGarbageUntilRecovery(VislamEstimator* e, const VislamOptions& o) {
  const EstimatorStats before = e->stats();
  std::mt19937 rng(5);
  const size_t bad_frames = static_cast<size_t>(o.health.max_rejected_frames);
  FeedResult last;
  for (size_t i = 0; i < bad_frames; ++i) {
    const size_t k = kFault + i;
    ASSERT_TRUE(e->feedTwist(twistAt(k)).accepted);
    EXPECT_EQ(delta(before, e->stats(), Counter::kDivergenceRecovery), 0) << "frame " << i;
    last = e->feedFeatures(garbageFrame(k, &rng));
    EXPECT_TRUE(last.accepted);
  }
  EXPECT_EQ(delta(before, e->stats(), Counter::kDivergenceRecovery), 1);
  EXPECT_NE(last.message.find("divergence"), std::string::npos) << last.message;
  EXPECT_EQ(e->activeLandmarkCount(), 0u);
  expectHealthy(*e, "after the recovery");
}

TEST(FaultHandling, DivergenceFromFramesWhoseObservationsAreMostlyGated) {
  for (DivergencePolicy policy : kPolicies) {
    SCOPED_TRACE(policyName(policy));
    std::printf("  policy %s\n", policyName(policy));
    // The garbage that passes the gate turns the pose. With the road tilt prior the filter
    // restores the tilt part of that afterwards (the world's level is observable through the
    // prior), which the motion since the restart counts as an error: the recovery itself is
    // checked without the prior, and with it the final position error must be no worse.
    VislamOptions o = faultOptions();
    o.health.divergence_policy = policy;
    VislamOptions without_tilt = o;
    without_tilt.vehicle.tilt_sigma = 0.0;
    VislamEstimator e = startedEstimator(without_tilt);
    feedGarbageUntilRecovery(&e, without_tilt);
    if (policy == DivergencePolicy::kResetFilter) {
      // Restarted at the current pose with the prior covariance (of the pose as published).
      const Matrix6d P = e.poseCovarianceWorld();
      const double p2 = o.prior.position_sigma * o.prior.position_sigma;
      const double r2 = o.prior.rotation_sigma * o.prior.rotation_sigma;
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(P(i, i), p2, 1e-3 * p2) << "position " << i;
        EXPECT_NEAR(P(i + 3, i + 3), r2, 1e-3 * r2) << "rotation " << i;
      }
    }
    const size_t restart = kFault + static_cast<size_t>(o.health.max_rejected_frames);
    expectRecovers(&e, restart, without_tilt, Check::kMotionAfterRestart);
    VislamEstimator with_tilt = startedEstimator(o);
    feedGarbageUntilRecovery(&with_tilt, o);
    runFrames(&with_tilt, restart, kFrames);
    expectHealthy(with_tilt, "end of the drive, tilt prior");
    const double error_without = positionError(e, kFrames - 1);
    const double error_with = positionError(with_tilt, kFrames - 1);
    std::printf("    final position error with the tilt prior %.3f m, without %.3f m\n", error_with,
                error_without);
    EXPECT_LE(error_with, error_without + 0.1);
  }
}

double positionSigma(const VislamEstimator& e) {
  return std::sqrt(e.poseCovarianceWorld().diagonal().head<3>().maxCoeff());
}

TEST(FaultHandling, DivergenceFromPositionSigmaBeyondTheHealthLimit) {
  // health/max_position_sigma = 0.2 m, below what the drive reaches (the clean drive's position
  // sigma passes 0.2 m near frame 225). Each recovery must be counted and reported, leave the
  // position sigma within the limit, and not be followed by another one at once (a recovery
  // loop leaves the filter dead reckoning for good); the filter must work on afterwards.
  for (DivergencePolicy policy : kPolicies) {
    SCOPED_TRACE(policyName(policy));
    VislamOptions o = faultOptions();
    o.health.divergence_policy = policy;
    o.health.max_position_sigma = 0.2;
    VislamEstimator e(o);
    ASSERT_TRUE(e.setCalibration(drive().calibration));
    std::vector<size_t> recoveries;
    std::vector<Eigen::Matrix4d> poses;
    for (size_t k = 0; k < kFrames; ++k) {
      step(&e, k);
      poses.push_back(e.worldTImu().matrix());
      if (e.stats().get(Counter::kDivergenceRecovery) > recoveries.size()) {
        recoveries.push_back(k);
        if (recoveries.size() <= 3) {
          expectHealthy(e, "after a recovery");
          EXPECT_LE(positionSigma(e), o.health.max_position_sigma) << "frame " << k;
          EXPECT_EQ(e.activeLandmarkCount(), 0u);
        }
      }
    }
    std::printf("  policy %s: %zu recoveries, at frames", policyName(policy), recoveries.size());
    for (size_t i = 0; i < recoveries.size() && i < 8; ++i) std::printf(" %zu", recoveries[i]);
    std::printf("%s\n", recoveries.size() > 8 ? " ..." : "");
    EXPECT_EQ(e.stats().get(Counter::kDivergenceRecovery), recoveries.size());
    ASSERT_GE(recoveries.size(), 1u);
    size_t min_spacing = kFrames;
    for (size_t i = 1; i < recoveries.size(); ++i) {
      min_spacing = std::min(min_spacing, recoveries[i] - recoveries[i - 1]);
    }
    EXPECT_GE(min_spacing, 10u) << "recovery loop: " << recoveries.size() << " recoveries";
    expectHealthy(e, "end of the drive");
    // The motion from the first recovery to the next one (or the end), against the clean drive
    // (default health limit) over the same frames.
    const size_t from = recoveries[0] + 1;
    const size_t to = recoveries.size() > 1 ? recoveries[1] - 1 : kFrames - 1;
    ASSERT_GE(to, from + 30);
    const std::vector<Eigen::Matrix4d> clean = cleanPoses(faultOptions());
    const double reference = motionError(clean[from], clean[to], from, to);
    const double error = motionError(poses[from], poses[to], from, to);
    std::printf("    motion error over frames %zu-%zu %.3f m (clean drive %.3f m)\n", from, to,
                error, reference);
    EXPECT_LE(error, 2.0 * reference + 0.1);
  }
}

}  // namespace
}  // namespace ekf_vislam
