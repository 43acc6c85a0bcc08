// Offline runner: a bag in, trajectory.tum + landmarks.csv + stats.json out. No roscore.
//
//   rosrun ekf_vislam vislam_offline --bag IN.bag --out DIR [--mode slam|mapping|deadreckoning]
//       [--config FILE] [--imu-frame NAME] [--twist-topic T] [--features-topic T]
//       [--left-info-topic T] [--right-info-topic T] [--tf-static-topic T]
//       [--imu-topic T] [--wheel-odometry-topic T] [--combiner-config FILE]
//
// A bag without the twist topic but with a gyro (sensor_msgs/Imu) and a wheel odometry
// (nav_msgs/Odometry) gets its twist from TwistCombiner, as twist_combiner_node makes it live.
//
// Feeds the estimator through the same conversions, MeasurementSequencer and EstimatorRunner as
// the nodelet, so the nodelet's trajectory on the same bag is the same.
#include "ekf_vislam/core/estimator_hints.h"
#include "ekf_vislam/core/estimator_runner.h"
#include "ekf_vislam/core/health_monitor.h"
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/ros/bag_reader.h"
#include "ekf_vislam/ros/conversions.h"
#include "ekf_vislam/ros/heap_allocation.h"
#include "ekf_vislam/ros/vislam_ros_options.h"

#ifdef EKF_VISLAM_HAVE_ROSLIB
#include <ros/package.h>
#endif

#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace ekf_vislam;

const char* kUsage =
    "usage: vislam_offline --bag IN.bag --out DIR [--mode slam|mapping|deadreckoning]\n"
    "                      [--config FILE] [--imu-frame NAME] [--twist-topic T]\n"
    "                      [--features-topic T] [--left-info-topic T] [--right-info-topic T]\n"
    "                      [--tf-static-topic T] [--imu-topic T] [--wheel-odometry-topic T]\n"
    "                      [--combiner-config FILE]\n"
    "Runs the EKF on a bag without a roscore and writes DIR/trajectory.tum (world_T_imu after\n"
    "every feature frame), DIR/trajectory_covariance.txt (each pose's reported 6x6 covariance:\n"
    "t, then 36 row-major entries, world axes x y z rx ry rz; evaluate.py reads it for the\n"
    "NEES), DIR/landmarks.csv (id, x, y, z, sigmas, observations) and DIR/stats.json\n"
    "(counters, per-frame ms, wall time, memory, online calibration). --mode overrides the\n"
    "config's mode; the default config is config/default.yaml of the ekf_vislam package. A bag\n"
    "with no twist topic but a gyro (--imu-topic, /imu/data) and a wheel odometry\n"
    "(--wheel-odometry-topic, /wheel/odometry) gets its twist combined from them (options:\n"
    "--combiner-config, default the built-in ones of config/twist_combiner.yaml).\n";

bool fileExists(const std::string& path) {
  struct stat info;
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

std::string defaultConfigPath() {
#ifdef EKF_VISLAM_HAVE_ROSLIB
  if (std::getenv("ROS_PACKAGE_PATH") != nullptr) {
    const std::string package = ros::package::getPath("ekf_vislam");
    if (!package.empty() && fileExists(package + "/config/default.yaml")) {
      return package + "/config/default.yaml";
    }
  }
#endif
#ifdef EKF_VISLAM_SOURCE_DIR
  if (fileExists(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml")) {
    return std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml";
  }
#endif
  return "";
}

int fail(const std::string& message) {
  std::cerr << "vislam_offline: " << message << std::endl;
  return 1;
}

class Progress {
 public:
  Progress() : enabled_(::isatty(STDERR_FILENO) == 1) {}
  void update(double fraction) {
    if (!enabled_) return;
    const int percent =
        static_cast<int>(std::floor(100.0 * std::min(1.0, std::max(0.0, fraction))));
    if (percent == last_) return;
    last_ = percent;
    const int width = 40;
    const int filled = percent * width / 100;
    std::fprintf(stderr, "\r[%s%s] %3d%%", std::string(filled, '#').c_str(),
                 std::string(width - filled, ' ').c_str(), percent);
    std::fflush(stderr);
  }
  void done() {
    if (enabled_ && last_ >= 0) std::fprintf(stderr, "\r%60s\r", "");
  }

 private:
  bool enabled_;
  int last_ = -1;
};

using Arguments = std::map<std::string, std::string>;

/// Parses the command line into *args; an exit code when the program must stop (help: 0,
/// usage errors: 2).
std::optional<int> parseArguments(int argc, char** argv, Arguments* args) {
  static const std::set<std::string> known = {"--bag",
                                              "--out",
                                              "--mode",
                                              "--config",
                                              "--imu-frame",
                                              "--twist-topic",
                                              "--features-topic",
                                              "--left-info-topic",
                                              "--right-info-topic",
                                              "--tf-static-topic",
                                              "--imu-topic",
                                              "--wheel-odometry-topic",
                                              "--combiner-config"};
  for (int i = 1; i < argc; ++i) {
    std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      return 0;
    }
    std::string value;
    const size_t eq = flag.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) {
      value = flag.substr(eq + 1);
      flag = flag.substr(0, eq);
    }
    if (known.count(flag) == 0) {
      std::cerr << "vislam_offline: unknown argument " << flag << "\n" << kUsage;
      return 2;
    }
    if (!inline_value) {
      if (i + 1 >= argc) {
        std::cerr << "vislam_offline: " << flag << " needs a value\n" << kUsage;
        return 2;
      }
      value = argv[++i];
    }
    (*args)[flag] = value;
  }
  if ((*args)["--bag"].empty() || (*args)["--out"].empty()) {
    std::cerr << "vislam_offline: --bag and --out are required\n" << kUsage;
    return 2;
  }
  return std::nullopt;
}

/// The same keys as the nodelet reads from the parameter server, then the command-line
/// overrides. False with *error.
bool loadOptions(Arguments& args, VislamOptions* options, VislamRosOptions* ros_options,
                 std::string* error) {
  std::string config = args["--config"];
  if (config.empty()) config = defaultConfigPath();
  if (config.empty()) {
    *error = "no --config given and config/default.yaml of ekf_vislam not found";
    return false;
  }
  YamlParameterSource source(config);
  if (!source.ok()) {
    *error = "cannot read config " + source.error();
    return false;
  }
  if (!parseVislamOptions(source, options, error)) return false;
  if (!parseVislamRosOptions(source, ros_options, error)) return false;
  std::cerr << "vislam_offline: configuration " << config << "\n";
  const std::string unknown = unknownEstimatorKeys(source);
  if (!unknown.empty()) std::cerr << "vislam_offline: " << config << ": " << unknown << "\n";
  if (!args["--mode"].empty() && !parseMode(args["--mode"], &options->mode)) {
    *error = "unknown --mode " + args["--mode"] + " (slam, mapping or deadreckoning)";
    return false;
  }
  if (!args["--imu-frame"].empty()) ros_options->imu_frame = args["--imu-frame"];
  return true;
}

/// The combiner options of `path` ("" = the built-in defaults, those of
/// config/twist_combiner.yaml). False with *error.
bool loadCombinerOptions(const std::string& path, TwistCombinerOptions* options,
                         std::string* error) {
  if (path.empty()) return true;
  YamlParameterSource source(path);
  if (!source.ok()) {
    *error = "cannot read combiner config " + source.error();
    return false;
  }
  return parseTwistCombinerOptions(source, options, error);
}

void printCombinerSummary(const TwistCombiner& combiner) {
  const TwistCombinerCounters& c = combiner.counters();
  std::fprintf(stderr,
               "vislam_offline: twist combiner: %lu gyro and %lu wheel samples in, %lu twists "
               "out, %lu with the wheel velocity held, %lu dropped (no wheel velocity), %lu "
               "refused\n",
               static_cast<unsigned long>(c.angular_received),
               static_cast<unsigned long>(c.linear_received), static_cast<unsigned long>(c.twists),
               static_cast<unsigned long>(c.velocity_held),
               static_cast<unsigned long>(c.dropped_no_velocity),
               static_cast<unsigned long>(c.rejected_non_finite + c.rejected_not_increasing));
}

BagTopics topicsFrom(Arguments& args) {
  BagTopics topics;
  if (!args["--twist-topic"].empty()) topics.twist = args["--twist-topic"];
  if (!args["--features-topic"].empty()) topics.features = args["--features-topic"];
  if (!args["--left-info-topic"].empty()) topics.left_info = args["--left-info-topic"];
  if (!args["--right-info-topic"].empty()) topics.right_info = args["--right-info-topic"];
  if (!args["--tf-static-topic"].empty()) topics.tf_static = args["--tf-static-topic"];
  if (!args["--imu-topic"].empty()) topics.imu_data = args["--imu-topic"];
  if (!args["--wheel-odometry-topic"].empty()) {
    topics.wheel_odometry = args["--wheel-odometry-topic"];
  }
  return topics;
}

/// True when the bag has no twist but a gyro and a wheel odometry to combine one from.
bool combinesTwist(const BagReader& bag, const BagTopics& topics) {
  return bag.messageCount(topics.twist) == 0 && bag.messageCount(topics.imu_data) > 0 &&
         bag.messageCount(topics.wheel_odometry) > 0;
}

/// Every topic present and of its type (the twist: any of the three of ros/twist_type, or the
/// gyro and wheel odometry it is combined from).
bool checkBagTopics(const BagReader& bag, const BagTopics& topics, bool needs_features,
                    bool combined, std::string* error) {
  if (topics.twist == topics.features) {
    *error = "the twist and feature topics must differ";
    return false;
  }
  std::vector<std::string> required = {topics.twist};
  if (combined) required = {topics.imu_data, topics.wheel_odometry};
  if (needs_features) required.push_back(topics.features);
  for (const std::string& topic : required) {
    if (bag.messageCount(topic) == 0) {
      *error = "no messages on " + topic +
               (combined ? ""
                         : " (nor on both " + topics.imu_data + " and " + topics.wheel_odometry +
                               " to combine a twist from)");
      return false;
    }
  }
  const std::string twist_type = bag.dataType(topics.twist);
  if (!combined && twist_type != "geometry_msgs/TwistStamped" &&
      twist_type != "geometry_msgs/TwistWithCovarianceStamped" &&
      twist_type != "nav_msgs/Odometry") {
    *error = topics.twist + " holds " + twist_type +
             ", expected geometry_msgs/TwistStamped, geometry_msgs/TwistWithCovarianceStamped "
             "or nav_msgs/Odometry";
    return false;
  }
  const std::pair<std::string, std::string> expected_types[] = {
      {topics.features, "ekf_vislam/StereoFeatureArray"},
      {topics.left_info, "sensor_msgs/CameraInfo"},
      {topics.right_info, "sensor_msgs/CameraInfo"},
      {topics.tf_static, "tf2_msgs/TFMessage"},
      {topics.imu_data, "sensor_msgs/Imu"},
      {topics.wheel_odometry, "nav_msgs/Odometry"}};
  for (const auto& [topic, type] : expected_types) {
    const std::string actual = bag.dataType(topic);
    if (!actual.empty() && actual != type) {
      *error = topic + " holds " + actual + ", expected " + type;
      return false;
    }
  }
  return true;
}

enum class CalibrationStatus { kBuilt, kMissing, kInvalid };

/// Calibration from the bag's camera_info pair and /tf_static, or the ros/calibration override:
/// built, missing a piece, or refused for its values.
CalibrationStatus calibrationFromBag(const BagCalibrationData& data, const BagTopics& topics,
                                     const VislamRosOptions& ros_options,
                                     StereoCalibration* calibration, std::string* error) {
  CalibrationBuilder builder(ros_options.calibration);
  if (builder.needsProjections() && data.has_left_info && data.has_right_info) {
    builder.setProjections(ros_conversions::projectionOf(data.left_info),
                           ros_conversions::projectionOf(data.right_info), error);
  }
  if (builder.needsImuTCam() && !data.camera_frame.empty()) {
    Eigen::Isometry3d imu_T_cam;
    if (lookupStaticTransform(data.static_transforms, ros_options.imu_frame, data.camera_frame,
                              &imu_T_cam, error)) {
      builder.setImuTCam(imu_T_cam);
    } else {
      std::cerr << "vislam_offline: " << *error << " (from " << topics.tf_static << ")\n";
    }
  }
  if (builder.build(calibration, error)) return CalibrationStatus::kBuilt;
  *error +=
      " (bag topics " + topics.left_info + ", " + topics.right_info + ", " + topics.tf_static + ")";
  return builder.complete() ? CalibrationStatus::kInvalid : CalibrationStatus::kMissing;
}

// The bag's camera calibration given to the estimator. Dead reckoning does without one; wrong
// values fail in every mode. False with *error saying why.
bool setBagCalibration(const BagCalibrationData& data, const BagTopics& topics,
                       const VislamRosOptions& ros_options, bool needs_features,
                       EstimatorRunner* runner, std::string* error) {
  StereoCalibration calibration;
  switch (calibrationFromBag(data, topics, ros_options, &calibration, error)) {
    case CalibrationStatus::kBuilt:
      if (runner->estimator().setCalibration(calibration, error)) return true;
      [[fallthrough]];
    case CalibrationStatus::kInvalid: *error = "invalid calibration: " + *error; return false;
    case CalibrationStatus::kMissing:
      if (needs_features) {
        *error = "no calibration: " + *error;
        return false;
      }
      std::cerr << "vislam_offline: dead reckoning without a calibration: " << *error << "\n";
      return true;
  }
  return true;
}

// The camera_info messages unlike the first of their camera (none counted when ros/calibration
// gives the intrinsics), warned: the estimator keeps the first pair's calibration, as the node.
uint64_t changedCameraInfo(const BagCalibrationData& data, const VislamRosOptions& ros_options) {
  if (ros_options.calibration.has_intrinsics || data.camera_info_changed == 0) return 0;
  std::cerr << "vislam_offline: warning: " << data.camera_info_changed
            << " camera_info message(s) differ from the first of their camera: ignored, the "
               "estimator keeps the calibration of the first pair (as the node does)\n";
  return data.camera_info_changed;
}

// The twist combiner's counters for stats.json (none without a combiner).
std::map<std::string, double> combinerStats(const TwistCombiner* combiner) {
  std::map<std::string, double> stats;
  if (combiner == nullptr) return stats;
  const TwistCombinerCounters& c = combiner->counters();
  const std::pair<const char*, uint64_t> counts[] = {
      {"gyro_samples", c.angular_received},
      {"wheel_samples", c.linear_received},
      {"twists", c.twists},
      {"velocity_held", c.velocity_held},
      {"dropped_no_velocity", c.dropped_no_velocity},
      {"refused", c.rejected_non_finite + c.rejected_not_increasing}};
  for (const auto& [key, count] : counts) {
    stats[std::string("twist_combiner_") + key] = static_cast<double>(count);
  }
  return stats;
}

void printSummary(const EstimatorRunner& runner, const std::string& out_dir) {
  const RunSummary summary = runner.summary();
  const ProcessingTimes& times = runner.times();
  const EstimatorStats& stats = runner.estimator().stats();
  const Eigen::Vector3d p = runner.estimator().worldTImu().translation();
  std::fprintf(stderr,
               "vislam_offline: %s, %lu frames, %lu twists, %zu landmarks (%zu in the map), %lu "
               "observations "
               "used, %lu rejected, %.2f ms/frame (p99 %.2f), %.1f s wall, final position "
               "(%.2f, %.2f, %.2f) m -> %s\n",
               summary.mode.c_str(), static_cast<unsigned long>(summary.frames),
               static_cast<unsigned long>(summary.twists), summary.landmarks_total,
               summary.landmarks_in_map,
               static_cast<unsigned long>(stats.get(Counter::kObservationUpdate) +
                                          stats.get(Counter::kObservationInitialized)),
               static_cast<unsigned long>(stats.observationsRejected()), times.mean(),
               times.percentile(0.99), summary.wall_s, p.x(), p.y(), p.z(), out_dir.c_str());
  if (const uint64_t at_rest = stats.get(Counter::kFrameAtRest); at_rest > 0) {
    std::fprintf(stderr,
                 "vislam_offline: at rest in %lu frames (standstill/): the pose held, the gyro "
                 "bias measured by %lu twist samples\n",
                 static_cast<unsigned long>(at_rest),
                 static_cast<unsigned long>(stats.get(Counter::kTwistAtRest)));
  }
  const VislamEstimator& estimator = runner.estimator();
  const VislamOptions& options = estimator.options();
  const StateHints state = stateHints(estimator);
  std::vector<std::string> hints = {
      disagreementHint(options.mode, stats.get(Counter::kObsGated),
                       stats.get(Counter::kObservationUpdate)),
      widenedPredictionHint(stats.get(Counter::kFramePredictionWidened),
                            stats.get(Counter::kFrameUsed)),
      sparseObservationsHint(options.mode, stats.get(Counter::kObservationUpdate),
                             stats.get(Counter::kFrameUsed)),
      accelerometerHint(stats.get(Counter::kAccelImplausible) + stats.get(Counter::kAccelNonFinite),
                        stats.get(Counter::kAccelUsed)),
      featureGeometryHint(stats.get(Counter::kObsRowMismatch), stats.get(Counter::kObsDisparity),
                          stats.observationsScreened())};
  for (const std::string* hint : state.all()) hints.push_back(*hint);
  for (const std::string& hint : hints) {
    if (!hint.empty()) std::fprintf(stderr, "vislam_offline: warning: %s\n", hint.c_str());
  }
}

int run(int argc, char** argv) {
  Arguments args;
  if (const std::optional<int> exit_code = parseArguments(argc, argv, &args)) return *exit_code;
  VislamOptions options;
  VislamRosOptions ros_options;
  std::string error;
  if (!loadOptions(args, &options, &ros_options, &error)) return fail(error);

  const BagTopics topics = topicsFrom(args);
  BagReader bag;
  if (!bag.open(args["--bag"], topics, &error)) return fail(error);
  const bool needs_features = options.mode != EstimatorMode::kDeadReckoning;
  const bool combined = combinesTwist(bag, topics);
  if (!checkBagTopics(bag, topics, needs_features, combined, &error)) {
    return fail("bag " + args["--bag"] + ": " + error);
  }
  BagCalibrationData data;
  if (!bag.readCalibrationData(&data, &error)) return fail(error);
  bag.setTwistFrames(ros_options.imu_frame, data.static_transforms);
  if (combined) {
    TwistCombinerOptions combiner_options;
    if (!loadCombinerOptions(args["--combiner-config"], &combiner_options, &error)) {
      return fail(error);
    }
    bag.useTwistCombiner(combiner_options, ros_options.time_jump_reset);
    std::cerr << "vislam_offline: no " << topics.twist << ": the twist is combined from "
              << topics.imu_data << " and " << topics.wheel_odometry << " ("
              << describeTwistCombinerOptions(combiner_options) << ")\n";
  }
  if (usesAccelerometer(options) && bag.messageCount(topics.imu_data) > 0) {
    bag.useAccelerometer();
    std::cerr << "vislam_offline: the accelerometer of " << topics.imu_data
              << " holds roll and pitch (gravity/enabled)\n";
  }
  EstimatorRunner runner(options, {ros_options.sequencer_max_delay,
                                   static_cast<size_t>(ros_options.sequencer_max_buffered)});
  if (!setBagCalibration(data, topics, ros_options, needs_features, &runner, &error)) {
    return fail(error);
  }
  const uint64_t camera_info_changed = changedCameraInfo(data, ros_options);

  runner.enableTimeJumpReset(ros_options.time_jump_reset);  // as the node does
  runner.startClock();
  Progress progress;
  const bool ok = bag.forEachMeasurement(
      [&](Measurement&& measurement, double fraction) {
        runner.push(std::move(measurement));
        runner.processReady();
        progress.update(fraction);
      },
      &error);
  progress.done();
  if (!ok) return fail(error);
  if (runner.timeJumpResets() > 0) {
    std::cerr << "vislam_offline: time went back " << runner.timeJumpResets()
              << " time(s) in the bag (ros/time_jump_reset): the estimator was reset, the "
                 "outputs hold the part after the last reset\n";
  }
  runner.flush();
  std::map<std::string, double> extra_stats = combinerStats(bag.twistCombiner());
  extra_stats["camera_info_changed"] = static_cast<double>(camera_info_changed);
  if (!runner.save(args["--out"], &error, extra_stats)) return fail(error);
  printSummary(runner, args["--out"]);
  if (const TwistCombiner* combiner = bag.twistCombiner()) printCombinerSummary(*combiner);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ekf_vislam::keepLargeAllocationsOnHeap();
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "vislam_offline: " << e.what() << std::endl;
    return 1;
  } catch (...) {
    std::cerr << "vislam_offline: unexpected error" << std::endl;
    return 1;
  }
}
