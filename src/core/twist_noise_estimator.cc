#include "ekf_vislam/core/twist_noise_estimator.h"

#include "ekf_vislam/core/chi_square.h"
#include "ekf_vislam/core/median.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ekf_vislam {

namespace {
constexpr double kChiSquare1Median = 0.454936;
}  // namespace

TwistNoiseEstimator::TwistNoiseEstimator(int window, int min_samples)
    : window_(std::max(3, window)), min_samples_(std::max(3, std::min(min_samples, window))) {}

void TwistNoiseEstimator::add(const TwistData& twist) {
  if (previous_ && before_previous_) {
    const double period = twist.stamp - previous_->stamp;
    const double previous_period = previous_->stamp - before_previous_->stamp;
    if (period > 0.0 && std::abs(period - previous_period) <= 0.5 * previous_period) {
      push(before_previous_->v_imu, previous_->v_imu, twist.v_imu, &linear_);
      push(before_previous_->w_imu, previous_->w_imu, twist.w_imu, &angular_);
      if (!linear_.empty()) linear_sigma_ = sigmaOf(linear_);
      if (!angular_.empty()) angular_sigma_ = sigmaOf(angular_);
    } else {
      previous_.reset();
    }
  }
  before_previous_ = previous_;
  previous_ = twist;
}

void TwistNoiseEstimator::push(const Eigen::Vector3d& before, const Eigen::Vector3d& previous,
                               const Eigen::Vector3d& now, std::deque<double>* squares) {
  for (int i = 0; i < 3; ++i) {
    if (before(i) == previous(i) && previous(i) == now(i)) continue;  // a held value
    const double second_difference = now(i) - 2.0 * previous(i) + before(i);
    squares->push_back(second_difference * second_difference);
  }
  while (squares->size() > 3 * static_cast<size_t>(window_)) squares->pop_front();
}

double TwistNoiseEstimator::sigmaOf(const std::deque<double>& squares) {
  std::vector<double> values(squares.begin(), squares.end());
  return std::sqrt(upperMedian(&values) / (6.0 * kChiSquare1Median));
}

bool TwistNoiseEstimator::exceeds(const std::deque<double>& squares, double sigma,
                                  double probability) {
  if (squares.empty() || !(sigma > 0.0)) return false;
  double sum = 0.0;
  for (double square : squares) sum += square;
  const int dof = static_cast<int>(squares.size());
  return sum / (6.0 * sigma * sigma) > chiSquareQuantile(probability, dof);
}

}  // namespace ekf_vislam
