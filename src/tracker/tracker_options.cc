#include "ekf_vislam/tracker/tracker_options.h"

#include "ekf_vislam/core/option_reader.h"

namespace ekf_vislam {

namespace {

constexpr EnumNames<FeatureDetectorType, 2> kDetectorNames{
    {{"fast", FeatureDetectorType::kFast}, {"shi_tomasi", FeatureDetectorType::kShiTomasi}}};
constexpr EnumNames<TemporalOutlierCheck, 3> kCheckNames{
    {{"none", TemporalOutlierCheck::kNone},
     {"fundamental", TemporalOutlierCheck::kFundamental},
     {"pnp", TemporalOutlierCheck::kPnp}}};

/// The key table: every key once, with its field and range (config/tracker.yaml documents them
/// in the same order). `Options` is TrackerOptions or const TrackerOptions.
template <typename Options, typename Visitor>
void visitTrackerOptions(Options& o, Visitor& v) {
  v.number("input/max_rate_hz", o.max_rate_hz, Bound::kNonNegative);
  v.choice("detector/type", o.detector, kDetectorNames);
  v.integer("detector/grid_cols", o.grid_cols, Bound::kAtLeastOne);
  v.integer("detector/grid_rows", o.grid_rows, Bound::kAtLeastOne);
  v.integer("detector/max_features_per_cell", o.max_features_per_cell, Bound::kAtLeastOne);
  v.number("detector/min_feature_distance", o.min_feature_distance, Bound::kNonNegative);
  v.integer("detector/fast_threshold", o.fast_threshold, Bound::kAtLeastOne);
  v.number("detector/shi_tomasi_quality", o.shi_tomasi_quality, Bound::kOpenUnit);
  v.integer("detector/border_px", o.border_px, Bound::kNonNegative);
  v.integer("detector/confirm_frames", o.confirm_frames, Bound::kNonNegative);
  v.integer("klt/window_size", o.window_size, Bound::kAtLeastOne);
  v.integer("klt/pyramid_levels", o.pyramid_levels, Bound::kNonNegative);
  v.integer("klt/max_iterations", o.max_iterations, Bound::kAtLeastOne);
  v.number("klt/epsilon", o.epsilon, Bound::kPositive);
  v.number("klt/forward_backward_px", o.forward_backward_px, Bound::kPositive);
  v.integer("klt/back_check_levels", o.back_check_levels, Bound::kNonNegative);
  v.flag("klt/predict_with_last_motion", o.predict_with_last_motion);
  v.flag("klt/exposure_compensation", o.exposure_compensation);
  v.flag("refine/enabled", o.refine);
  v.integer("refine/patch_size", o.refine_patch_size, Bound::kAtLeastOne);
  v.integer("refine/max_iterations", o.refine_max_iterations, Bound::kAtLeastOne);
  v.number("refine/epsilon", o.refine_epsilon, Bound::kPositive);
  v.number("refine/max_shift_px", o.refine_max_shift_px, Bound::kPositive);
  v.number("refine/min_zncc", o.refine_min_zncc, Bound::kNonNegative);
  v.number("refine/max_scale_change", o.refine_max_scale_change, Bound::kPositive);
  v.flag("refine/end_failed_tracks", o.refine_end_failed);
  v.flag("refine/stereo", o.refine_stereo);
  v.integer("stereo/window_size", o.stereo_window_size, Bound::kAtLeastOne);
  v.integer("stereo/pyramid_levels", o.stereo_pyramid_levels, Bound::kNonNegative);
  v.number("stereo/row_tolerance_px", o.row_tolerance_px, Bound::kPositive);
  v.number("stereo/min_disparity_px", o.min_disparity_px, Bound::kPositive);
  v.number("stereo/max_disparity_px", o.max_disparity_px, Bound::kPositive);
  v.number("stereo/back_check_px", o.stereo_back_check_px, Bound::kPositive);
  v.number("stereo/disparity_check_px", o.disparity_check_px, Bound::kNonNegative);
  v.number("stereo/disparity_check_relative", o.disparity_check_relative, Bound::kNonNegative);
  v.flag("stereo/correct_disparity_offset", o.correct_disparity_offset);
  v.choice("ransac/type", o.outlier_check, kCheckNames);
  v.number("ransac/threshold_px", o.ransac_threshold_px, Bound::kPositive);
  v.number("ransac/confidence", o.ransac_confidence, Bound::kOpenUnit);
  v.integer("ransac/iterations", o.ransac_iterations, Bound::kAtLeastOne);
  v.integer("ransac/min_points", o.min_ransac_points, Bound::kAtLeastOne);
  v.number("ransac/max_pnp_depth_m", o.max_pnp_depth_m, Bound::kPositive);
  v.text("mask/left", o.mask_left);
  v.text("mask/right", o.mask_right);
}

/// The key table of the nodelet's ros/ options. `Options` is StereoTrackerRosOptions or const.
template <typename Options, typename Visitor>
void visitTrackerRosOptions(Options& o, Visitor& v) {
  v.integer("ros/queue_size", o.queue_size, Bound::kAtLeastOne);
  v.number("ros/max_stamp_difference", o.max_stamp_difference, Bound::kNonNegative);
  v.choice("ros/image_transport", o.image_transport, kImageTransportNames);
  v.flag("ros/rectify", o.rectify);
  v.integer("ros/image_bits", o.image_bits, Bound::kNonNegative);
  v.flag("ros/use_twist", o.use_twist);
  v.choice("ros/twist_type", o.twist_type, kTwistMessageTypeNames);
  v.number("ros/max_twist_wait", o.max_twist_wait, Bound::kNonNegative);
  v.number("ros/diagnostic_period", o.diagnostic_period, Bound::kPositive);
  v.number("ros/time_jump_reset", o.time_jump_reset, Bound::kNonNegative);
  v.number("ros/max_backlog_mb", o.max_backlog_mb, Bound::kPositive);
}

constexpr auto kTable = [](auto& options, auto& visitor) { visitTrackerOptions(options, visitor); };
constexpr auto kRosTable = [](auto& options, auto& visitor) {
  visitTrackerRosOptions(options, visitor);
};

}  // namespace

bool parseTrackerOptions(const ParameterSource& source, TrackerOptions* options,
                         std::string* error) {
  OptionReader reader(source, error);
  TrackerOptions o = *options;
  visitTrackerOptions(o, reader);
  if (!reader.ok()) return false;
  *options = o;
  return true;
}

std::string TrackerOptions::validate() const {
  OptionValidator validator;
  visitTrackerOptions(*this, validator);
  // What a bound cannot say.
  if (fast_threshold > 255) validator.fail("'detector/fast_threshold' must be 1..255");
  if (window_size < 5 || window_size % 2 == 0) {
    validator.fail("'klt/window_size' must be odd and >= 5");
  }
  if (pyramid_levels > 8) validator.fail("'klt/pyramid_levels' must be 0..8");
  if (refine_patch_size < 5 || refine_patch_size % 2 == 0) {
    validator.fail("'refine/patch_size' must be odd and >= 5");
  }
  if (refine_min_zncc > 1) validator.fail("'refine/min_zncc' must be 0..1");
  if (refine_max_scale_change <= 1) validator.fail("'refine/max_scale_change' must exceed 1");
  if (stereo_window_size < 5 || stereo_window_size % 2 == 0) {
    validator.fail("'stereo/window_size' must be odd and >= 5");
  }
  if (stereo_pyramid_levels > 8) validator.fail("'stereo/pyramid_levels' must be 0..8");
  if (max_disparity_px <= min_disparity_px) {
    validator.fail("'stereo/max_disparity_px' must exceed 'stereo/min_disparity_px'");
  }
  if (min_ransac_points < 8) validator.fail("'ransac/min_points' must be >= 8");
  return validator.error();
}

std::string describeOptions(const TrackerOptions& options) {
  return describeOptionTable(options, kTable);
}

std::vector<OptionKeyList::Key> trackerOptionKeys() {
  return optionTableKeys<TrackerOptions>(kTable);
}

bool parseTrackerRosOptions(const ParameterSource& source, StereoTrackerRosOptions* options,
                            std::string* error) {
  return readOptionTable(source, kRosTable, options, error,
                         [](const StereoTrackerRosOptions& o, OptionValidator* validator) {
                           if (o.image_bits != 0 && (o.image_bits < 8 || o.image_bits > 16)) {
                             validator->fail(
                                 "ros/image_bits must be 0 (read from the images) or "
                                 "8-16, not " +
                                 std::to_string(o.image_bits));
                           }
                         });
}

std::vector<OptionKeyList::Key> trackerRosOptionKeys() {
  return optionTableKeys<StereoTrackerRosOptions>(kRosTable);
}

std::string unknownTrackerKeys(const ParameterSource& source) {
  std::vector<std::string> known;
  appendKeyNames(trackerOptionKeys(), &known);
  appendKeyNames(trackerRosOptionKeys(), &known);
  return describeUnknownKeys(unknownKeys(source, known), known);
}

}  // namespace ekf_vislam
