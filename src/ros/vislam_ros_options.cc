#include "ekf_vislam/ros/vislam_ros_options.h"

#include <cmath>
#include <sstream>
#include <vector>

namespace ekf_vislam {

namespace {

class Reader {
 public:
  Reader(const ParameterSource& source, std::string* error) : source_(source), error_(error) {}

  template <typename T, typename Getter>
  void read(const std::string& key, T* value, Getter getter, const char* type_name) {
    if (failed_ || !source_.has(key)) return;
    T parsed;
    if (!(source_.*getter)(key, &parsed)) {
      fail(key, std::string("expected ") + type_name);
      return;
    }
    *value = parsed;
  }
  void readDouble(const std::string& key, double* v) {
    read(key, v, &ParameterSource::getDouble, "a number");
  }
  void readInt(const std::string& key, int* v) { read(key, v, &ParameterSource::getInt, "an integer"); }
  void readBool(const std::string& key, bool* v) {
    read(key, v, &ParameterSource::getBool, "true or false");
  }
  void readString(const std::string& key, std::string* v) {
    read(key, v, &ParameterSource::getString, "a string");
  }
  bool has(const std::string& key) const { return source_.has(key); }
  void fail(const std::string& key, const std::string& why) {
    if (failed_) return;
    failed_ = true;
    if (error_) *error_ = source_.describe() + ": " + key + ": " + why;
  }
  bool failed() const { return failed_; }

 private:
  const ParameterSource& source_;
  std::string* error_;
  bool failed_ = false;
};

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

}  // namespace

std::string VislamRosOptions::validate() const {
  std::ostringstream why;
  if (world_frame.empty() || imu_frame.empty()) {
    why << "ros/world_frame and ros/imu_frame must not be empty";
  } else if (world_frame == imu_frame) {
    why << "ros/world_frame and ros/imu_frame must differ";
  } else if (twist_type != "twist_stamped" && twist_type != "twist_with_covariance" &&
             twist_type != "odometry") {
    why << "ros/twist_type must be twist_stamped, twist_with_covariance or odometry, not '"
        << twist_type << "'";
  } else if (!(landmark_marker_rate >= 0.0) || !(path_rate >= 0.0)) {
    why << "ros/landmark_marker_rate and ros/path_rate must be >= 0";
  } else if (!(diagnostic_period > 0.0)) {
    why << "ros/diagnostic_period must be > 0";
  } else if (!(input_timeout > 0.0)) {
    why << "ros/input_timeout must be > 0";
  } else if (!(calibration_wait >= 0.0)) {
    why << "ros/calibration_wait must be >= 0";
  } else if (!(sequencer_max_delay >= 0.0)) {
    why << "ros/sequencer_max_delay must be >= 0";
  } else if (sequencer_max_buffered < 1 || queue_size < 1) {
    why << "ros/sequencer_max_buffered and ros/queue_size must be >= 1";
  } else if (!(landmark_sigma_good > 0.0) || !(landmark_sigma_bad > landmark_sigma_good)) {
    why << "need 0 < ros/landmark_sigma_good < ros/landmark_sigma_bad";
  } else if (!(landmark_point_size > 0.0)) {
    why << "ros/landmark_point_size must be > 0";
  } else if (!(ellipsoid_sigma_scale > 0.0)) {
    why << "ros/ellipsoid_sigma_scale must be > 0";
  }
  return why.str();
}

bool parseVislamRosOptions(const ParameterSource& source, VislamRosOptions* options,
                           std::string* error) {
  Reader r(source, error);
  VislamRosOptions o = *options;
  r.readString("ros/world_frame", &o.world_frame);
  r.readString("ros/imu_frame", &o.imu_frame);
  r.readString("ros/twist_type", &o.twist_type);
  r.readBool("ros/publish_tf", &o.publish_tf);
  r.readDouble("ros/landmark_marker_rate", &o.landmark_marker_rate);
  r.readBool("ros/covariance_ellipsoids", &o.covariance_ellipsoids);
  r.readDouble("ros/ellipsoid_sigma_scale", &o.ellipsoid_sigma_scale);
  r.readDouble("ros/landmark_point_size", &o.landmark_point_size);
  r.readDouble("ros/landmark_sigma_good", &o.landmark_sigma_good);
  r.readDouble("ros/landmark_sigma_bad", &o.landmark_sigma_bad);
  r.readDouble("ros/path_rate", &o.path_rate);
  r.readDouble("ros/diagnostic_period", &o.diagnostic_period);
  r.readDouble("ros/input_timeout", &o.input_timeout);
  r.readDouble("ros/calibration_wait", &o.calibration_wait);
  r.readDouble("ros/sequencer_max_delay", &o.sequencer_max_delay);
  r.readInt("ros/sequencer_max_buffered", &o.sequencer_max_buffered);
  r.readInt("ros/queue_size", &o.queue_size);
  r.readString("ros/output_dir", &o.output_dir);

  // Calibration override.
  const char* intrinsic_keys[] = {"fx", "fy", "cx", "cy", "baseline"};
  double* intrinsic_values[] = {&o.calibration.calibration.fx, &o.calibration.calibration.fy,
                                &o.calibration.calibration.cx, &o.calibration.calibration.cy,
                                &o.calibration.calibration.baseline};
  int given = 0;
  for (int i = 0; i < 5; ++i) {
    const std::string key = std::string("ros/calibration/") + intrinsic_keys[i];
    if (r.has(key)) ++given;
    r.readDouble(key, intrinsic_values[i]);
  }
  if (given != 0 && given != 5 && !r.failed()) {
    r.fail("ros/calibration", "give all of fx, fy, cx, cy, baseline or none");
  }
  o.calibration.has_intrinsics = given == 5;
  r.readInt("ros/calibration/image_width", &o.calibration.calibration.image_width);
  r.readInt("ros/calibration/image_height", &o.calibration.calibration.image_height);
  if (r.has("ros/calibration/cam_T_imu") && !r.failed()) {
    std::string text;
    r.readString("ros/calibration/cam_T_imu", &text);
    std::vector<double> numbers;
    if (!r.failed()) {
      if (!parseNumbers(text, &numbers) || numbers.size() != 16) {
        r.fail("ros/calibration/cam_T_imu", "expected 16 numbers (4x4, row-major)");
      } else {
        Eigen::Matrix4d m;
        for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = numbers[i];
        o.calibration.calibration.cam_T_imu.matrix() = m;
        o.calibration.has_extrinsic = true;
      }
    }
  }
  if (r.failed()) return false;
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
  out << "ros: world_frame=" << o.world_frame << " imu_frame=" << o.imu_frame
      << " twist_type=" << o.twist_type
      << " publish_tf=" << o.publish_tf << " landmark_marker_rate=" << o.landmark_marker_rate
      << " covariance_ellipsoids=" << o.covariance_ellipsoids
      << " ellipsoid_sigma_scale=" << o.ellipsoid_sigma_scale
      << " landmark_point_size=" << o.landmark_point_size
      << " landmark_sigma_good=" << o.landmark_sigma_good
      << " landmark_sigma_bad=" << o.landmark_sigma_bad << " path_rate=" << o.path_rate
      << " diagnostic_period=" << o.diagnostic_period << " input_timeout=" << o.input_timeout
      << " calibration_wait=" << o.calibration_wait
      << " sequencer_max_delay=" << o.sequencer_max_delay
      << " sequencer_max_buffered=" << o.sequencer_max_buffered
      << " queue_size=" << o.queue_size << " output_dir="
      << (o.output_dir.empty() ? "(none)" : o.output_dir);
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

}  // namespace ekf_vislam
