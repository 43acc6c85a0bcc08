#include "ekf_vislam/tracker/tracker_options.h"

#include "ekf_vislam/core/option_reader.h"

#include <cmath>
#include <initializer_list>
#include <sstream>
#include <utility>

namespace ekf_vislam {

namespace {

const std::initializer_list<std::pair<const char*, FeatureDetectorType>> kDetectorNames = {
    {"fast", FeatureDetectorType::kFast}, {"shi_tomasi", FeatureDetectorType::kShiTomasi}};
const std::initializer_list<std::pair<const char*, TemporalOutlierCheck>> kCheckNames = {
    {"none", TemporalOutlierCheck::kNone},
    {"fundamental", TemporalOutlierCheck::kFundamental},
    {"pnp", TemporalOutlierCheck::kPnp}};

template <typename Enum>
const char* nameOf(Enum value, std::initializer_list<std::pair<const char*, Enum>> names) {
  for (const auto& [name, e] : names) {
    if (e == value) return name;
  }
  return "unknown";
}


void require(bool condition, const char* what, std::ostringstream* why) {
  if (!condition) *why << what << "\n";
}

}  // namespace

bool parseTrackerOptions(const ParameterSource& source, TrackerOptions* o, std::string* error) {
  OptionReader r(source, error);
  r.choice("detector/type", &o->detector, kDetectorNames);
  r.integer("detector/grid_cols", &o->grid_cols);
  r.integer("detector/grid_rows", &o->grid_rows);
  r.integer("detector/max_features_per_cell", &o->max_features_per_cell);
  r.number("detector/min_feature_distance", &o->min_feature_distance);
  r.integer("detector/fast_threshold", &o->fast_threshold);
  r.number("detector/shi_tomasi_quality", &o->shi_tomasi_quality);
  r.integer("detector/border_px", &o->border_px);
  r.integer("detector/confirm_frames", &o->confirm_frames);
  r.integer("klt/window_size", &o->window_size);
  r.integer("klt/pyramid_levels", &o->pyramid_levels);
  r.integer("klt/max_iterations", &o->max_iterations);
  r.number("klt/epsilon", &o->epsilon);
  r.number("klt/forward_backward_px", &o->forward_backward_px);
  r.flag("klt/predict_with_last_motion", &o->predict_with_last_motion);
  r.integer("stereo/window_size", &o->stereo_window_size);
  r.integer("stereo/pyramid_levels", &o->stereo_pyramid_levels);
  r.number("stereo/row_tolerance_px", &o->row_tolerance_px);
  r.number("stereo/min_disparity_px", &o->min_disparity_px);
  r.number("stereo/max_disparity_px", &o->max_disparity_px);
  r.number("stereo/back_check_px", &o->stereo_back_check_px);
  r.number("stereo/disparity_check_px", &o->disparity_check_px);
  r.number("stereo/disparity_check_relative", &o->disparity_check_relative);
  r.choice("ransac/type", &o->outlier_check, kCheckNames);
  r.number("ransac/threshold_px", &o->ransac_threshold_px);
  r.number("ransac/confidence", &o->ransac_confidence);
  r.integer("ransac/iterations", &o->ransac_iterations);
  r.integer("ransac/min_points", &o->min_ransac_points);
  r.number("ransac/max_pnp_depth_m", &o->max_pnp_depth_m);
  return r.ok();
}

std::string TrackerOptions::validate() const {
  std::ostringstream why;
  require(grid_cols >= 1 && grid_rows >= 1, "detector/grid_cols and grid_rows must be >= 1", &why);
  require(max_features_per_cell >= 1, "detector/max_features_per_cell must be >= 1", &why);
  require(min_feature_distance >= 0, "detector/min_feature_distance must be >= 0", &why);
  require(fast_threshold >= 1 && fast_threshold <= 255, "detector/fast_threshold must be 1..255",
          &why);
  require(shi_tomasi_quality > 0 && shi_tomasi_quality < 1,
          "detector/shi_tomasi_quality must be in (0, 1)", &why);
  require(border_px >= 0, "detector/border_px must be >= 0", &why);
  require(confirm_frames >= 0, "detector/confirm_frames must be >= 0", &why);
  require(window_size >= 5 && window_size % 2 == 1, "klt/window_size must be odd and >= 5", &why);
  require(pyramid_levels >= 0 && pyramid_levels <= 8, "klt/pyramid_levels must be 0..8", &why);
  require(max_iterations >= 1, "klt/max_iterations must be >= 1", &why);
  require(epsilon > 0, "klt/epsilon must be > 0", &why);
  require(forward_backward_px > 0, "klt/forward_backward_px must be > 0", &why);
  require(stereo_window_size >= 5 && stereo_window_size % 2 == 1,
          "stereo/window_size must be odd and >= 5", &why);
  require(stereo_pyramid_levels >= 0 && stereo_pyramid_levels <= 8,
          "stereo/pyramid_levels must be 0..8", &why);
  require(row_tolerance_px > 0, "stereo/row_tolerance_px must be > 0", &why);
  require(min_disparity_px > 0, "stereo/min_disparity_px must be > 0 (positive disparity)", &why);
  require(max_disparity_px > min_disparity_px,
          "stereo/max_disparity_px must exceed min_disparity_px", &why);
  require(stereo_back_check_px > 0, "stereo/back_check_px must be > 0", &why);
  require(disparity_check_px >= 0, "stereo/disparity_check_px must be >= 0", &why);
  require(disparity_check_relative >= 0, "stereo/disparity_check_relative must be >= 0", &why);
  require(ransac_threshold_px > 0, "ransac/threshold_px must be > 0", &why);
  require(ransac_confidence > 0 && ransac_confidence < 1, "ransac/confidence must be in (0, 1)",
          &why);
  require(ransac_iterations >= 1, "ransac/iterations must be >= 1", &why);
  require(min_ransac_points >= 8, "ransac/min_points must be >= 8", &why);
  require(max_pnp_depth_m > 0, "ransac/max_pnp_depth_m must be > 0", &why);
  return why.str();
}

std::string describeOptions(const TrackerOptions& o) {
  std::ostringstream s;
  s << "detector/type: " << nameOf(o.detector, kDetectorNames) << "\n"
    << "detector/grid_cols: " << o.grid_cols << "\n"
    << "detector/grid_rows: " << o.grid_rows << "\n"
    << "detector/max_features_per_cell: " << o.max_features_per_cell << "\n"
    << "detector/min_feature_distance: " << o.min_feature_distance << "\n"
    << "detector/fast_threshold: " << o.fast_threshold << "\n"
    << "detector/shi_tomasi_quality: " << o.shi_tomasi_quality << "\n"
    << "detector/border_px: " << o.border_px << "\n"
    << "detector/confirm_frames: " << o.confirm_frames << "\n"
    << "klt/window_size: " << o.window_size << "\n"
    << "klt/pyramid_levels: " << o.pyramid_levels << "\n"
    << "klt/max_iterations: " << o.max_iterations << "\n"
    << "klt/epsilon: " << o.epsilon << "\n"
    << "klt/forward_backward_px: " << o.forward_backward_px << "\n"
    << "klt/predict_with_last_motion: " << (o.predict_with_last_motion ? "true" : "false") << "\n"
    << "stereo/window_size: " << o.stereo_window_size << "\n"
    << "stereo/pyramid_levels: " << o.stereo_pyramid_levels << "\n"
    << "stereo/row_tolerance_px: " << o.row_tolerance_px << "\n"
    << "stereo/min_disparity_px: " << o.min_disparity_px << "\n"
    << "stereo/max_disparity_px: " << o.max_disparity_px << "\n"
    << "stereo/back_check_px: " << o.stereo_back_check_px << "\n"
    << "stereo/disparity_check_px: " << o.disparity_check_px << "\n"
    << "stereo/disparity_check_relative: " << o.disparity_check_relative << "\n"
    << "ransac/type: " << nameOf(o.outlier_check, kCheckNames) << "\n"
    << "ransac/threshold_px: " << o.ransac_threshold_px << "\n"
    << "ransac/confidence: " << o.ransac_confidence << "\n"
    << "ransac/iterations: " << o.ransac_iterations << "\n"
    << "ransac/min_points: " << o.min_ransac_points << "\n"
    << "ransac/max_pnp_depth_m: " << o.max_pnp_depth_m;
  return s.str();
}

}  // namespace ekf_vislam
