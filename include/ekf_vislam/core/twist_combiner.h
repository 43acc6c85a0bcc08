// TwistCombiner: the body twist the estimator needs, made from the two sensors a ground robot
// usually has: a gyro (angular velocity, IMU frame) and a wheel odometry (linear velocity of its
// own frame, e.g. base_link). No ROS.
//
// One twist per `imu_samples_per_twist` gyro samples, stamped at the last of them: the mean
// angular velocity of those samples (the twist at t_k drives [t_k-1, t_k] in the estimator) and
// the linear velocity interpolated linearly between the two wheel samples around t_k, moved to
// the IMU origin (v_imu = R v_base + p x w_imu for imu_T_base = (R, p)). A twist waits until a
// wheel sample at or after its stamp has arrived. When the gyro stream has run
// `max_velocity_wait` s ahead of the wheel stream and (live, given a wall clock) the twist has
// waited that long in wall time too (lateStreamWaitIsOver), the last wheel velocity is held
// (counted): a wheel stream that is only late loses nothing, and the output depends on the stamps
// and the order of the inputs, not on the machine's load. A twist whose nearest wheel sample is
// more than `max_velocity_age` s away is dropped (counted).
#pragma once

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/core/option_table.h"
#include "ekf_vislam/core/parameter_source.h"
#include "ekf_vislam/core/twist_noise_estimator.h"
#include "ekf_vislam/core/types.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace ekf_vislam {

struct TwistCombinerOptions {
  int imu_samples_per_twist = 1;   ///< gyro samples averaged into one twist
  double max_velocity_wait = 2.0;  ///< s (gyro and wall time) a twist waits for a wheel sample
  double max_velocity_age = 0.5;   ///< s: a wheel sample further from the twist is not used
};

/// Reads the combiner/ keys of `source` into *options (unset keys keep their value) and checks
/// their ranges; false with *error naming the key.
bool parseTwistCombinerOptions(const ParameterSource& source, TwistCombinerOptions* options,
                               std::string* error);
/// Every key of the combiner/ table ("combiner/imu_samples_per_twist", ...).
std::vector<OptionKeyList::Key> twistCombinerOptionKeys();
/// "combiner: key=value ..." lines (logged at start).
std::string describeTwistCombinerOptions(const TwistCombinerOptions& options);

/// A gyro sample, already in the IMU frame.
struct AngularVelocitySample {
  double stamp = 0.0;
  Eigen::Vector3d w_imu = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< rad^2/s^2; all zero: unknown
};

/// A wheel-odometry sample: the linear velocity of its own frame, in that frame's axes, and
/// where that frame is (imu_T_base: base coordinates to IMU coordinates).
struct LinearVelocitySample {
  double stamp = 0.0;
  Eigen::Vector3d v_base = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< m^2/s^2; all zero: unknown
  Eigen::Isometry3d imu_T_base = Eigen::Isometry3d::Identity();
};

struct TwistCombinerCounters {
  uint64_t angular_received = 0;
  uint64_t linear_received = 0;
  uint64_t twists = 0;                   ///< twists out
  uint64_t velocity_held = 0;            ///< twists with a wheel velocity held, not interpolated
  uint64_t dropped_no_velocity = 0;      ///< twists without a wheel sample near enough
  uint64_t rejected_non_finite = 0;      ///< input samples with NaN/Inf
  uint64_t rejected_not_increasing = 0;  ///< input samples not newer than the previous one
};

class TwistCombiner {
 public:
  explicit TwistCombiner(const TwistCombinerOptions& options) : options_(options) {}

  /// Add one sample arrived at wall time `now` (s, steadyClockSeconds; kNoWallClock: message time
  /// alone, a recorded log read at once); false (counted, *why says why) when it is refused: not
  /// finite, or not newer than the previous sample of its stream. Twists that become complete go
  /// to takeReady().
  bool addAngularVelocity(const AngularVelocitySample& sample, std::string* why = nullptr,
                          double now = kNoWallClock);
  bool addLinearVelocity(const LinearVelocitySample& sample, std::string* why = nullptr,
                         double now = kNoWallClock);
  /// Live: completes the twists whose wait for the wheel stream is over at wall time `now`
  /// (call it now and then; each add does it too).
  void releaseWaiting(double now);

  /// The twists completed since the last call, in stamp order. Each carries the covariance of
  /// one twist sample once both sensors' noise is known: from the messages when they carry one,
  /// else estimated from each stream's own samples (TwistNoiseEstimator), and scaled to the
  /// twist's period so that each sensor keeps its noise density (a 20 Hz wheel velocity
  /// interpolated at 100 Hz is not 100 Hz white noise: the estimator's own online estimate,
  /// made from the twists, would read it as nearly noise-free).
  std::vector<TwistData> takeReady();

  /// Forgets every sample (time went back); the counters stay.
  void reset();

  const TwistCombinerCounters& counters() const { return counters_; }

 private:
  /// A twist's gyro part: the mean of its samples.
  struct AngularGroup {
    double stamp = 0.0;
    double period = 0.0;  ///< s the twist covers: its samples' count x the gyro period
    Eigen::Vector3d w_imu = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of the mean; zero: unknown
    double arrival = kArrivedLongAgo;                      ///< wall s
  };
  /// A wheel sample as admitted, with the stream's estimated per-sample variance (0: not ready)
  /// and period as they were then, so that a twist's covariance depends on the samples up to its
  /// wheel samples only, not on when the other stream's messages came.
  struct AdmittedLinearVelocity : LinearVelocitySample {
    double estimated_variance = 0.0;
    double period = 0.0;
  };
  /// Per-sample covariance of the wheel velocity at `t` between `before` and `after` (messages'
  /// or estimated), scaled to the twist's period; zero while unknown.
  Eigen::Matrix3d wheelCovariance(const AngularGroup& group, const AdmittedLinearVelocity& before,
                                  const AdmittedLinearVelocity& after, double weight_after) const;
  /// One input stream: its last stamp, its sample period and its white noise, estimated from
  /// its own samples (windows as the estimator's defaults: noise/twist_noise_window 300,
  /// twist_noise_min_samples 5).
  struct StreamState {
    double last_stamp = -1e300;
    double period = 0.0;  ///< s between its last two samples
    TwistNoiseEstimator noise{300, 5};
  };
  /// Counts and refuses a sample that is not finite or not newer than the stream's last one;
  /// else advances the stream (period, noise estimate from `for_noise`).
  bool admit(bool finite, const TwistData& for_noise, StreamState* stream, const char* what,
             std::string* why);
  /// `now`: the wall time the last gyro sample arrived (kNoWallClock: none).
  void closeGroupIfFull(double now);
  /// False while the group must wait for a wheel sample (at wall time `now`).
  bool tryCombine(const AngularGroup& group, double newest_angular_stamp, double now);
  TwistData combine(const AngularGroup& group, const AdmittedLinearVelocity& before,
                    const AdmittedLinearVelocity& after, double weight_after) const;
  void pruneLinear(double released_stamp);

  TwistCombinerOptions options_;
  std::vector<AngularVelocitySample> open_group_;  ///< gyro samples of the twist being filled
  std::deque<AngularGroup> waiting_;               ///< complete gyro parts, stamp order
  std::deque<AdmittedLinearVelocity> linear_;      ///< wheel samples, stamp order
  std::vector<TwistData> ready_;
  StreamState gyro_, wheel_;
  TwistCombinerCounters counters_;
};

}  // namespace ekf_vislam
