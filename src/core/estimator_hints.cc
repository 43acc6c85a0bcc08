#include "ekf_vislam/core/estimator_hints.h"

#include "ekf_vislam/core/health_monitor.h"
#include "ekf_vislam/core/vislam_estimator.h"

namespace ekf_vislam {

StateHints stateHints(const VislamEstimator& estimator) {
  const VislamOptions& options = estimator.options();
  StateHints hints;
  hints.travel = travelDirectionHint(estimator.travelDirection(), options.vehicle);
  hints.tilt = roadTiltHint(estimator.roadTiltDegrees(), options.vehicle);
  hints.slow =
      slowDriveHint(options.mode, estimator.meanTwistSpeed(), estimator.angularNoiseDensity(),
                    estimator.twistSpeedSamples(), countsDisparityOffset(options));
  hints.speed = speedErrorHint(estimator.twistSpeedScaleShown(), estimator.twistSpeedScaleSigma(),
                               options.noise.twist_speed_scale_sigma);
  hints.offset = disparityOffsetHint(estimator.disparityOffsetMonitor().error(),
                                     estimator.disparityOffsetCountedShown(),
                                     options.intrinsic.disparity_offset_counted_sigma);
  return hints;
}

}  // namespace ekf_vislam
