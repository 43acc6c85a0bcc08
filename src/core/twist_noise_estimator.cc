#include "ekf_vislam/core/twist_noise_estimator.h"

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
      push(&linear_, twist.v_imu - 2.0 * previous_->v_imu + before_previous_->v_imu);
      push(&angular_, twist.w_imu - 2.0 * previous_->w_imu + before_previous_->w_imu);
      linear_sigma_ = sigmaOf(linear_);
      angular_sigma_ = sigmaOf(angular_);
    } else {
      previous_.reset();
    }
  }
  before_previous_ = previous_;
  previous_ = twist;
}

void TwistNoiseEstimator::push(std::deque<double>* squares,
                               const Eigen::Vector3d& second_difference) {
  for (int i = 0; i < 3; ++i) squares->push_back(second_difference(i) * second_difference(i));
  while (squares->size() > 3 * static_cast<size_t>(window_)) squares->pop_front();
}

double TwistNoiseEstimator::sigmaOf(const std::deque<double>& squares) {
  std::vector<double> values(squares.begin(), squares.end());
  auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return std::sqrt(*middle / (6.0 * kChiSquare1Median));
}

}  // namespace ekf_vislam
