#include "ekf_vislam/core/twist_combiner.h"

#include "ekf_vislam/core/late_stream_wait.h"
#include "ekf_vislam/core/option_reader.h"
#include "ekf_vislam/core/se3.h"

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

namespace {

template <typename Options, typename Visitor>
void visitTwistCombinerOptions(Options& o, Visitor& v) {
  v.integer("combiner/imu_samples_per_twist", o.imu_samples_per_twist, Bound::kAtLeastOne);
  v.number("combiner/max_velocity_wait", o.max_velocity_wait, Bound::kNonNegative);
  v.number("combiner/max_velocity_age", o.max_velocity_age, Bound::kPositive);
}

constexpr auto kTable = [](auto& options, auto& visitor) {
  visitTwistCombinerOptions(options, visitor);
};

void setWhy(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
}

}  // namespace

bool parseTwistCombinerOptions(const ParameterSource& source, TwistCombinerOptions* options,
                               std::string* error) {
  return readOptionTable(source, kTable, options, error);
}

std::vector<OptionKeyList::Key> twistCombinerOptionKeys() {
  return optionTableKeys<TwistCombinerOptions>(kTable);
}

std::string describeTwistCombinerOptions(const TwistCombinerOptions& options) {
  return describeOptionTable(options, kTable);
}

bool TwistCombiner::admit(bool finite, const TwistData& for_noise, StreamState* stream,
                          const char* what, std::string* why) {
  if (!finite || !std::isfinite(for_noise.stamp)) {
    ++counters_.rejected_non_finite;
    setWhy(why, std::string(what) + " or its covariance not finite");
    return false;
  }
  if (for_noise.stamp <= stream->last_stamp) {
    ++counters_.rejected_not_increasing;
    setWhy(why, std::string(what) + " stamp not after the previous one");
    return false;
  }
  if (stream->last_stamp > -1e300) stream->period = for_noise.stamp - stream->last_stamp;
  stream->last_stamp = for_noise.stamp;
  stream->noise.add(for_noise);
  return true;
}

bool TwistCombiner::addAngularVelocity(const AngularVelocitySample& sample, std::string* why,
                                       double now) {
  ++counters_.angular_received;
  TwistData for_noise;
  for_noise.stamp = sample.stamp;
  for_noise.w_imu = sample.w_imu;
  const bool finite = sample.w_imu.allFinite() && sample.covariance.allFinite();
  if (!admit(finite, for_noise, &gyro_, "angular velocity", why)) return false;
  open_group_.push_back(sample);
  closeGroupIfFull(now);
  releaseWaiting(now);
  return true;
}

bool TwistCombiner::addLinearVelocity(const LinearVelocitySample& sample, std::string* why,
                                      double now) {
  ++counters_.linear_received;
  TwistData for_noise;
  for_noise.stamp = sample.stamp;
  for_noise.v_imu = sample.v_base;
  const bool finite = sample.v_base.allFinite() && sample.covariance.allFinite() &&
                      sample.imu_T_base.matrix().allFinite();
  if (!admit(finite, for_noise, &wheel_, "linear velocity", why)) return false;
  AdmittedLinearVelocity admitted{sample};
  if (wheel_.noise.linearReady()) {
    admitted.estimated_variance = std::pow(wheel_.noise.linearSigma(), 2);
  }
  admitted.period = wheel_.period;
  linear_.push_back(admitted);
  releaseWaiting(now);
  return true;
}

std::vector<TwistData> TwistCombiner::takeReady() {
  std::vector<TwistData> out;
  out.swap(ready_);
  return out;
}

void TwistCombiner::reset() {
  open_group_.clear();
  waiting_.clear();
  linear_.clear();
  ready_.clear();
  gyro_ = StreamState();
  wheel_ = StreamState();
}

void TwistCombiner::closeGroupIfFull(double now) {
  if (static_cast<int>(open_group_.size()) < options_.imu_samples_per_twist) return;
  AngularGroup group;
  group.stamp = open_group_.back().stamp;
  if (now != kNoWallClock) group.arrival = now;
  bool all_have_covariance = true;
  for (const AngularVelocitySample& sample : open_group_) {
    group.w_imu += sample.w_imu;
    group.covariance += sample.covariance;
    all_have_covariance = all_have_covariance && !sample.covariance.isZero(0.0);
  }
  const double n = static_cast<double>(open_group_.size());
  group.w_imu /= n;
  group.period = n * gyro_.period;
  // The mean of n samples of independent noise: covariance / n.
  if (all_have_covariance) {
    group.covariance /= n * n;
  } else if (gyro_.noise.angularReady()) {
    const double sigma = gyro_.noise.angularSigma();
    group.covariance = Eigen::Matrix3d::Identity() * (sigma * sigma / n);
  } else {
    group.covariance.setZero();
  }
  waiting_.push_back(group);
  open_group_.clear();
}

void TwistCombiner::releaseWaiting(double now) {
  while (!waiting_.empty() && tryCombine(waiting_.front(), gyro_.last_stamp, now)) {
    pruneLinear(waiting_.front().stamp);
    waiting_.pop_front();
  }
}

bool TwistCombiner::tryCombine(const AngularGroup& group, double newest_angular_stamp, double now) {
  const double t = group.stamp;
  // The first wheel sample at or after t, and the last one before it.
  auto after = std::lower_bound(
      linear_.begin(), linear_.end(), t,
      [](const AdmittedLinearVelocity& sample, double stamp) { return sample.stamp < stamp; });
  const bool has_before = after != linear_.begin();
  if (after != linear_.end()) {
    if (!has_before || after->stamp == t) {
      // Nothing before t (the wheel stream starts later), or a sample exactly at t.
      if (after->stamp - t > options_.max_velocity_age) {
        ++counters_.dropped_no_velocity;
        return true;
      }
      if (after->stamp != t) ++counters_.velocity_held;
      ready_.push_back(combine(group, *after, *after, 0.0));
    } else {
      const AdmittedLinearVelocity& before = *std::prev(after);
      const double weight_after = (t - before.stamp) / (after->stamp - before.stamp);
      ready_.push_back(combine(group, before, *after, weight_after));
    }
    ++counters_.twists;
    return true;
  }
  // No wheel sample at or after t yet: wait, unless the gyro stream is too far ahead and the twist
  // has waited as long in wall time.
  if (!lateStreamWaitIsOver(newest_angular_stamp - t, now - group.arrival,
                            options_.max_velocity_wait)) {
    return false;
  }
  if (!has_before || t - linear_.back().stamp > options_.max_velocity_age) {
    ++counters_.dropped_no_velocity;
    return true;
  }
  ++counters_.velocity_held;
  ++counters_.twists;
  ready_.push_back(combine(group, linear_.back(), linear_.back(), 0.0));
  return true;
}

TwistData TwistCombiner::combine(const AngularGroup& group, const AdmittedLinearVelocity& before,
                                 const AdmittedLinearVelocity& after, double weight_after) const {
  // Each wheel sample moved to the IMU origin with this twist's angular velocity, then
  // interpolated: v_imu = R v_base + p x w_imu, d v_imu / d w_imu = [p]x.
  auto at_imu = [&group](const LinearVelocitySample& sample) {
    const Eigen::Matrix3d R = sample.imu_T_base.linear();
    return Eigen::Vector3d(R * sample.v_base + sample.imu_T_base.translation().cross(group.w_imu));
  };
  const double weight_before = 1.0 - weight_after;
  TwistData twist;
  twist.stamp = group.stamp;
  twist.w_imu = group.w_imu;
  twist.v_imu = weight_before * at_imu(before) + weight_after * at_imu(after);
  const Eigen::Matrix3d cov_v_base = wheelCovariance(group, before, after, weight_after);
  if (!group.covariance.isZero(0.0) && !cov_v_base.isZero(0.0)) {
    const Eigen::Matrix3d R = before.imu_T_base.linear();
    const Eigen::Matrix3d p_hat = se3::hat(Eigen::Vector3d(before.imu_T_base.translation()));
    twist.covariance.topLeftCorner<3, 3>() =
        R * cov_v_base * R.transpose() + p_hat * group.covariance * p_hat.transpose();
    twist.covariance.topRightCorner<3, 3>() = p_hat * group.covariance;
    twist.covariance.bottomLeftCorner<3, 3>() = group.covariance * p_hat.transpose();
    twist.covariance.bottomRightCorner<3, 3>() = group.covariance;
  }
  return twist;
}

Eigen::Matrix3d TwistCombiner::wheelCovariance(const AngularGroup& group,
                                               const AdmittedLinearVelocity& before,
                                               const AdmittedLinearVelocity& after,
                                               double weight_after) const {
  Eigen::Matrix3d per_sample;
  if (!before.covariance.isZero(0.0) && !after.covariance.isZero(0.0)) {
    per_sample = (1.0 - weight_after) * before.covariance + weight_after * after.covariance;
  } else if (after.estimated_variance > 0.0) {
    per_sample = Eigen::Matrix3d::Identity() * after.estimated_variance;
  } else {
    return Eigen::Matrix3d::Zero();
  }
  // The wheel's density (per-sample variance x its period) over the twist's period.
  if (group.period > 0.0 && after.period > 0.0) per_sample *= after.period / group.period;
  return per_sample;
}

void TwistCombiner::pruneLinear(double released_stamp) {
  // Keep the last wheel sample before the released stamp (the next twist may interpolate from
  // it) and everything after.
  while (linear_.size() > 1 && linear_[1].stamp <= released_stamp) linear_.pop_front();
}

}  // namespace ekf_vislam
