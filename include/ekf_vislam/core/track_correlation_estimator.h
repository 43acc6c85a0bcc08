// Online estimate of how strongly a feature source's errors repeat along a track: the
// correlation of a track's residuals from one frame to the next, read after each update (the
// posterior residuals, so that the pose error the frame's tracks share is fitted out). White
// tracks read near 0; tracks that drift read near 1. An AR(1) error of correlation rho carries,
// over a track, the information of independent errors with (1 + rho) / (1 - rho) times the
// variance: that factor scales the observation noise of the reported covariance
// (noise/report_track_correlation). Exponential forgetting over about `window` pairs. No ROS.
#pragma once

#include <Eigen/Core>

namespace ekf_vislam {

class TrackCorrelationEstimator {
 public:
  /// window: residual pairs (one per re-observed track and frame) the estimate covers;
  /// min_pairs: pairs before it is used; max_correlation caps the estimate (and the factor).
  TrackCorrelationEstimator(int window, int min_pairs, double max_correlation);

  /// A track's posterior residual now and at its previous frame (same rows).
  void add(const Eigen::VectorXd& residual, const Eigen::VectorXd& previous_residual);

  bool ready() const { return pairs_ >= min_pairs_; }
  /// Pooled lag-one correlation in [0, max_correlation]; 0 until ready().
  double correlation() const;
  /// (1 + rho) / (1 - rho) of correlation(): 1 for white tracks.
  double varianceFactor() const;
  long pairs() const { return pairs_; }
  /// Forgets every pair (the estimator's reset).
  void reset() {
    pairs_ = 0;
    cross_ = current_ = previous_ = 0.0;
  }

 private:
  double forget_;
  long min_pairs_;
  double max_correlation_;
  long pairs_ = 0;
  double cross_ = 0.0;     ///< sum of r_k r_(k-1), forgotten
  double current_ = 0.0;   ///< sum of r_k^2
  double previous_ = 0.0;  ///< sum of r_(k-1)^2
};

}  // namespace ekf_vislam
