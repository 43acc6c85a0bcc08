#include "ekf_vislam/ros/vislam_ros_options.h"

#include "ekf_vislam/core/option_reader.h"

#include <cmath>
#include <sstream>
#include <vector>

namespace ekf_vislam {

namespace {

bool parseNumbers(const std::string& text, std::vector<double>* numbers) {
  std::string cleaned = text;
  for (char& c : cleaned) {
    if (c == ',' || c == '[' || c == ']' || c == ';') c = ' ';
  }
  std::istringstream in(cleaned);
  numbers->clear();
  double value;
  while (in >> value) numbers->push_back(value);
  return in.eof();
}

/// The key table of the ros/ options (the calibration override is read on its own: its keys
/// come as a group). `Options` is VislamRosOptions or const VislamRosOptions.
template <typename Options, typename Visitor>
void visitVislamRosOptions(Options& o, Visitor& v) {
  v.text("ros/world_frame", o.world_frame);
  v.text("ros/imu_frame", o.imu_frame);
  v.text("ros/base_frame", o.base_frame);
  v.choice("ros/twist_type", o.twist_type, kTwistMessageTypeNames);
  v.flag("ros/publish_tf", o.publish_tf);
  v.number("ros/landmark_marker_rate", o.landmark_marker_rate, Bound::kNonNegative);
  v.flag("ros/covariance_ellipsoids", o.covariance_ellipsoids);
  v.number("ros/ellipsoid_sigma_scale", o.ellipsoid_sigma_scale, Bound::kPositive);
  v.number("ros/landmark_point_size", o.landmark_point_size, Bound::kPositive);
  v.number("ros/landmark_sigma_good", o.landmark_sigma_good, Bound::kPositive);
  v.number("ros/landmark_sigma_bad", o.landmark_sigma_bad, Bound::kPositive);
  v.number("ros/path_rate", o.path_rate, Bound::kNonNegative);
  v.number("ros/diagnostic_period", o.diagnostic_period, Bound::kPositive);
  v.number("ros/input_timeout", o.input_timeout, Bound::kPositive);
  v.number("ros/calibration_wait", o.calibration_wait, Bound::kNonNegative);
  v.number("ros/sequencer_max_delay", o.sequencer_max_delay, Bound::kNonNegative);
  v.integer("ros/sequencer_max_buffered", o.sequencer_max_buffered, Bound::kAtLeastOne);
  v.integer("ros/queue_size", o.queue_size, Bound::kAtLeastOne);
  v.number("ros/time_jump_reset", o.time_jump_reset, Bound::kNonNegative);
  v.number("ros/tf_wait", o.tf_wait, Bound::kNonNegative);
  v.text("ros/output_dir", o.output_dir);
}

/// ros/calibration/...: all five intrinsics or none, optional image size, optional cam_T_imu.
void readCalibrationOverride(OptionReader* r, CalibrationOverride* c) {
  const char* intrinsic_keys[] = {"fx", "fy", "cx", "cy", "baseline"};
  double* intrinsic_values[] = {&c->calibration.fx, &c->calibration.fy, &c->calibration.cx,
                                &c->calibration.cy, &c->calibration.baseline};
  int given = 0;
  for (int i = 0; i < 5; ++i) {
    const std::string key = std::string("ros/calibration/") + intrinsic_keys[i];
    if (r->has(key)) ++given;
    r->number(key, intrinsic_values[i]);
  }
  if (given != 0 && given != 5)
    r->fail("ros/calibration", "all of fx, fy, cx, cy, baseline or none");
  c->has_intrinsics = given == 5;
  r->integer("ros/calibration/image_width", &c->calibration.image_width);
  r->integer("ros/calibration/image_height", &c->calibration.image_height);
  if (!r->has("ros/calibration/cam_T_imu") || !r->ok()) return;
  std::string text;
  r->text("ros/calibration/cam_T_imu", text);
  std::vector<double> numbers;
  if (!r->ok()) return;
  if (!parseNumbers(text, &numbers) || numbers.size() != 16) {
    r->fail("ros/calibration/cam_T_imu", "16 numbers (4x4, row-major)");
    return;
  }
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = numbers[i];
  c->calibration.cam_T_imu.matrix() = m;
  c->has_extrinsic = true;
}

constexpr auto kTable = [](auto& options, auto& visitor) {
  visitVislamRosOptions(options, visitor);
};

}  // namespace

std::string VislamRosOptions::validate() const {
  OptionValidator validator;
  visitVislamRosOptions(*this, validator);
  if (world_frame.empty() || imu_frame.empty()) {
    validator.fail("'ros/world_frame' and 'ros/imu_frame' must not be empty");
  } else if (world_frame == imu_frame || world_frame == base_frame) {
    validator.fail("'ros/world_frame' must differ from 'ros/imu_frame' and 'ros/base_frame'");
  }
  if (!(landmark_sigma_bad > landmark_sigma_good)) {
    validator.fail("'ros/landmark_sigma_bad' must exceed 'ros/landmark_sigma_good'");
  }
  return validator.error();
}

bool parseVislamRosOptions(const ParameterSource& source, VislamRosOptions* options,
                           std::string* error) {
  OptionReader reader(source, error);
  VislamRosOptions o = *options;
  visitVislamRosOptions(o, reader);
  readCalibrationOverride(&reader, &o.calibration);
  if (!reader.ok()) return false;
  const std::string why = o.validate();
  if (!why.empty()) {
    if (error) *error = source.describe() + ": " + why;
    return false;
  }
  *options = o;
  return true;
}

std::string describeOptions(const VislamRosOptions& o) {
  std::ostringstream out;
  out << describeOptionTable(o, kTable);
  if (o.calibration.has_intrinsics) {
    const StereoCalibration& c = o.calibration.calibration;
    out << "\nros/calibration (overrides camera_info): fx=" << c.fx << " fy=" << c.fy
        << " cx=" << c.cx << " cy=" << c.cy << " baseline=" << c.baseline;
  }
  if (o.calibration.has_extrinsic) {
    out << "\nros/calibration/cam_T_imu (overrides tf):\n"
        << o.calibration.calibration.cam_T_imu.matrix();
  }
  return out.str();
}

std::vector<OptionKeyList::Key> vislamRosOptionKeys() {
  return optionTableKeys<VislamRosOptions>(kTable);
}

std::string unknownEstimatorKeys(const ParameterSource& source) {
  std::vector<std::string> known;
  appendKeyNames(vislamOptionKeys(), &known);
  appendKeyNames(vislamRosOptionKeys(), &known);
  return describeUnknownKeys(unknownKeys(source, known, {"ros/calibration/"}), known);
}

}  // namespace ekf_vislam
