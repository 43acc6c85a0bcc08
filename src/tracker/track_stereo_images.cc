// track_stereo_images: runs the stereo tracker over a folder of rectified stereo images in the
// KITTI odometry layout and writes the tracks as a course dataset (.npz). See --help.
#include "ekf_vislam/core/output_writers.h"
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/tracker/debug_drawing.h"
#include "ekf_vislam/tracker/deep_image_scale.h"
#include "ekf_vislam/tracker/feature_columns.h"
#include "ekf_vislam/tracker/frame_rate_limit.h"
#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/kitti_sequence.h"
#include "ekf_vislam/tracker/npz_writer.h"
#include "ekf_vislam/tracker/pose_twist.h"
#include "ekf_vislam/tracker/stereo_rig_check.h"
#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/track_quality.h"
#include "ekf_vislam/tracker/twist_motion_prior.h"

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ekf_vislam {
namespace {

const char* kUsage =
    "usage: track_stereo_images (--folder DIR | --left DIR --right DIR --calib calib.txt\n"
    "           --times times.txt) --out OUT.npz [--poses poses.txt] [--config tracker.yaml]\n"
    "           [--twist-noise V W] [--gyro-offset B] [--seed N] [--time-offset S]\n"
    "           [--first-frame N] [--max-frames N] [--predict-with-twist] [--debug-dir DIR]\n"
    "           [--stats CSV] [--cameras L R] [--reuse-gap N] [--quiet]\n"
    "Tracks the rectified stereo images (KITTI odometry layout: calib.txt with P0 and P1,\n"
    "times.txt, optional poses.txt with world_T_cam0) and writes OUT.npz in the course layout:\n"
    "features (4,M,T; -1 where unobserved), K, b, time_stamps (1,T), image_size. With --poses\n"
    "also linear_velocity and rotational_velocity (3,T: the ground-truth body twist of a vehicle\n"
    "frame at the left camera, x along the poses' direction of travel, y left, z up, as a wheel\n"
    "odometry would give it, plus white noise V m/s and W rad/s per\n"
    "sample and axis (default 0.05 0.005) and a constant gyro offset B rad/s (default 0.001),\n"
    "seeded by N (default 0)), cam_T_imu, and OUT_groundtruth.tum (world_T_imu), and prints the\n"
    "track quality against the poses. --time-offset adds S seconds to every time (default 0).\n"
    "--folder: --left, --right, --calib and --times of a sequence folder: DIR/image_left and\n"
    "DIR/image_right, or KITTI's own DIR/image_0 and DIR/image_1 (image_L and image_R with\n"
    "--cameras), DIR/calib.txt, DIR/times.txt (each one given as well wins; --poses is not\n"
    "taken from the folder: give it to get the twist).\n"
    "--first-frame: starts at frame N of the folder (images, times and poses; default 0).\n"
    "--predict-with-twist (needs --poses): the tracker predicts each image's motion from that\n"
    "twist, as the nodelet does from imu/twist.\n"
    "--config: tracker options (config/tracker.yaml; absent keys keep the defaults; of its ros/\n"
    "group, image_bits for 16-bit images).\n"
    "--debug-dir: writes the debug drawing of every frame as DIR/NNNNNN.png.\n"
    "--stats: writes the tracker's per-frame counters and times (ms) as CSV.\n"
    "--cameras: the left and right images are KITTI's cameras L and R: their projections PL and\n"
    "PR of calib.txt (default 0 1; 2 3 for KITTI's colour cameras, whose poses are then moved\n"
    "from camera 0 to camera L).\n"
    "--reuse-gap: a column of features is taken by a later id once N frames have passed without\n"
    "its last id (the estimator starts an id that comes back as a new landmark); 0 gives every\n"
    "id its own column, as the course files do. Default: 0, unless that array would pass 1 GiB\n"
    "(a long sequence), then 10.\n";

struct Arguments {
  std::string folder, left, right, calib, times, out, poses, config, debug_dir, stats;
  TwistNoise noise;
  double time_offset = 0;
  long max_frames = -1;
  long first_frame = 0;
  long reuse_gap = -1;  ///< -1: 0, or kColumnReuseGap when a column per id passes 1 GiB
  bool quiet = false;
  bool predict_with_twist = false;
  KittiCameras cameras;
};

/// The IMU poses of --poses and their body twist (with the noise of --twist-noise etc.).
struct PoseTwist {
  Eigen::Matrix4d cam_T_imu = Eigen::Matrix4d::Identity();
  std::vector<Eigen::Matrix4d> world_T_imu;
  std::vector<Eigen::Vector3d> v, w;
};

/// --folder: the paths not given one by one.
void fillFromFolder(Arguments* args) {
  const KittiFolder parts = kittiFolderParts(args->folder, args->cameras);
  for (auto [given, found] : {std::pair{&args->left, &parts.left},
                              {&args->right, &parts.right},
                              {&args->calib, &parts.calib},
                              {&args->times, &parts.times}}) {
    if (given->empty()) *given = *found;
  }
}

bool parseArguments(int argc, char** argv, Arguments* args, std::string* error) {
  std::map<std::string, std::string*> paths = {
      {"--folder", &args->folder}, {"--left", &args->left},     {"--right", &args->right},
      {"--calib", &args->calib},   {"--times", &args->times},   {"--out", &args->out},
      {"--poses", &args->poses},   {"--config", &args->config}, {"--debug-dir", &args->debug_dir},
      {"--stats", &args->stats}};
  auto number = [&](int i, double* value) {
    if (i >= argc) return false;
    char* end = nullptr;
    *value = std::strtod(argv[i], &end);
    return end != argv[i] && *end == '\0' && std::isfinite(*value);
  };
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    double a = 0, b = 0;
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--quiet") {
      args->quiet = true;
    } else if (arg == "--predict-with-twist") {
      args->predict_with_twist = true;
    } else if (paths.count(arg) && i + 1 < argc) {
      *paths[arg] = argv[++i];
    } else if (arg == "--twist-noise" && number(i + 1, &a) && number(i + 2, &b) && a >= 0 &&
               b >= 0) {
      args->noise.linear_sigma = a;
      args->noise.angular_sigma = b;
      i += 2;
    } else if (arg == "--gyro-offset" && number(i + 1, &a)) {
      args->noise.gyro_offset = a;
      ++i;
    } else if (arg == "--seed" && number(i + 1, &a) && a >= 0) {
      args->noise.seed = static_cast<uint64_t>(a);
      ++i;
    } else if (arg == "--time-offset" && number(i + 1, &a)) {
      args->time_offset = a;
      ++i;
    } else if (arg == "--first-frame" && number(i + 1, &a) && a >= 0) {
      args->first_frame = static_cast<long>(a);
      ++i;
    } else if (arg == "--cameras" && number(i + 1, &a) && number(i + 2, &b) && a >= 0 && b >= 0 &&
               a != b && a == std::floor(a) && b == std::floor(b)) {
      args->cameras = {static_cast<int>(a), static_cast<int>(b)};
      i += 2;
    } else if (arg == "--reuse-gap" && number(i + 1, &a) && a >= 0 && a == std::floor(a)) {
      args->reuse_gap = static_cast<long>(a);
      ++i;
    } else if (arg == "--max-frames" && number(i + 1, &a) && a >= 1) {
      args->max_frames = static_cast<long>(a);
      ++i;
    } else {
      *error = "bad or incomplete argument '" + arg + "' (see --help)";
      return false;
    }
  }
  if (!args->folder.empty()) fillFromFolder(args);
  if (args->left.empty() || args->right.empty() || args->calib.empty() || args->times.empty() ||
      args->out.empty()) {
    *error = "--folder (or --left, --right, --calib, --times) and --out are required (see --help)";
    return false;
  }
  if (args->predict_with_twist && args->poses.empty()) {
    *error = "--predict-with-twist needs --poses (the twist comes from them)";
    return false;
  }

  return true;
}

/// The tracker's options and, of the ros/ group, ros/image_bits (16-bit images).
bool loadOptions(const std::string& path, TrackerOptions* options, int* image_bits,
                 std::string* error) {
  if (!path.empty()) {
    YamlParameterSource source(path);
    if (!source.ok()) {
      *error = source.error();
      return false;
    }
    StereoTrackerRosOptions ros_options;
    if (!parseTrackerOptions(source, options, error) ||
        !parseTrackerRosOptions(source, &ros_options, error)) {
      return false;
    }
    *image_bits = ros_options.image_bits;
    const std::string unknown = unknownTrackerKeys(source);
    if (!unknown.empty()) std::cerr << "track_stereo_images: " << path << ": " << unknown << "\n";
  }
  *error = options->validate();
  return error->empty();
}

/// The columns of the features array: --reuse-gap's, or by default one per id unless that
/// array would pass kFreshColumnsMaxBytes (said on stderr).
FeatureColumns featureColumns(const Arguments& args, const std::vector<StereoFrame>& frames) {
  if (args.reuse_gap >= 0) return assignFeatureColumns(frames, args.reuse_gap);
  FeatureColumns fresh = assignFeatureColumns(frames, 0);  // a column per id
  if (defaultReuseGap(fresh.columns, frames.size()) == 0) return fresh;
  const double fresh_bytes = freshColumnsBytes(fresh.columns, frames.size());
  FeatureColumns columns = assignFeatureColumns(frames, kColumnReuseGap);
  std::cerr << "track_stereo_images: note: " << columns.column_of_id.size() << " ids in "
            << columns.columns << " columns of features (a column taken again after "
            << kColumnReuseGap << " frames without its last id; one per id would take "
            << fresh_bytes / (1024.0 * 1024.0 * 1024.0) << " GiB); --reuse-gap 0 gives each id "
            << "its own\n";
  return columns;
}

// (4, M, T) row-major, -1 where unobserved.
std::vector<double> featureArray(const std::vector<StereoFrame>& frames,
                                 const FeatureColumns& columns) {
  const size_t M = columns.columns, T = frames.size();
  std::vector<double> data(4 * M * T, -1.0);
  for (size_t k = 0; k < T; ++k) {
    for (const TrackedFeature& f : frames[k].features) {
      const size_t c = columns.column_of_id.at(f.id);
      const double values[4] = {f.left.x, f.left.y, f.right.x, f.right.y};
      for (size_t row = 0; row < 4; ++row) data[(row * M + c) * T + k] = values[row];
    }
  }
  return data;
}

std::string stem(const std::string& path) {
  const std::string suffix = ".npz";
  if (path.size() > suffix.size() && path.compare(path.size() - 4, 4, suffix) == 0) {
    return path.substr(0, path.size() - 4);
  }
  return path;
}

bool writeGroundTruth(const std::string& path, const std::vector<double>& times,
                      const std::vector<Eigen::Matrix4d>& world_T_imu, std::string* error) {
  std::ofstream out(path);
  out.precision(9);
  for (size_t k = 0; k < times.size(); ++k) {
    const Eigen::Quaterniond q(Eigen::Matrix3d(world_T_imu[k].block<3, 3>(0, 0)));
    out << std::fixed << times[k] << " " << world_T_imu[k](0, 3) << " " << world_T_imu[k](1, 3)
        << " " << world_T_imu[k](2, 3) << " " << q.x() << " " << q.y() << " " << q.z() << " "
        << q.w() << "\n";
  }
  if (!out) *error = path + ": cannot write";
  return static_cast<bool>(out);
}

bool writeDataset(const Arguments& args, const KittiSequence& sequence,
                  const std::vector<StereoFrame>& frames, const PoseTwist& pose_twist,
                  const cv::Size& image_size, std::string* error) {
  const size_t T = frames.size();
  const StereoCalibration& c = sequence.calibration;
  NpzWriter npz;
  const FeatureColumns columns = featureColumns(args, frames);
  npz.addDoubles("features", {4, columns.columns, T}, featureArray(frames, columns));
  // A column holds several tracks: the bag writer lists them by age (dataset.py).
  if (columns.columns < columns.column_of_id.size()) {
    npz.addInts("feature_columns_shared", {}, {1});
  }
  npz.addDoubles("K", {3, 3}, {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1});
  npz.addDoubles("b", {}, {c.baseline});
  std::vector<double> stamps(T);
  for (size_t k = 0; k < T; ++k) stamps[k] = frames[k].stamp;
  npz.addDoubles("time_stamps", {1, T}, stamps);
  npz.addInts("image_size", {2}, {image_size.width, image_size.height});
  if (!pose_twist.world_T_imu.empty()) {
    const Eigen::Matrix4d& cam_T_imu = pose_twist.cam_T_imu;
    const std::vector<Eigen::Vector3d>& v = pose_twist.v;
    const std::vector<Eigen::Vector3d>& w = pose_twist.w;
    std::vector<double> linear(3 * T), angular(3 * T), extrinsic(16);
    for (size_t k = 0; k < T; ++k) {
      for (size_t axis = 0; axis < 3; ++axis) {
        linear[axis * T + k] = v[k][axis];
        angular[axis * T + k] = w[k][axis];
      }
    }
    for (int r = 0; r < 4; ++r) {
      for (int col = 0; col < 4; ++col) extrinsic[4 * r + col] = cam_T_imu(r, col);
    }
    npz.addDoubles("linear_velocity", {3, T}, linear);
    npz.addDoubles("rotational_velocity", {3, T}, angular);
    npz.addDoubles("cam_T_imu", {4, 4}, extrinsic);
    npz.addInts("cam_T_imu_translation_correct", {}, {1});
    if (!writeGroundTruth(stem(args.out) + "_groundtruth.tum", stamps, pose_twist.world_T_imu,
                          error)) {
      return false;
    }
  }
  return npz.write(args.out, error);
}

bool writeStats(const std::string& path, const std::vector<StereoFrame>& frames,
                std::string* error) {
  std::ofstream out(path);
  out << "frame,stamp,tracks_in,klt_lost,forward_backward_rejected,ransac_rejected,stereo_lost,"
         "disparity_rejected,detected,new_tracks,published,motion_estimated,ms_pyramids,"
         "ms_temporal,ms_ransac,ms_stereo,ms_detect,ms_total,refined,refine_failed,ms_refine,"
         "exposure_gain_temporal,exposure_gain_stereo,stereo_converged,stereo_row_failed,"
         "stereo_negative_disparity,stereo_row_offset_px,predicted_from_first_matches,crowded,"
         "disparity_offset_px,disparity_offset_sigma_px,stereo_roll_deg,stereo_roll_sigma_deg,"
         "stereo_roll_edge_px,disparity_offset_corrected_px,ids_renewed\n";
  out.precision(10);
  for (size_t k = 0; k < frames.size(); ++k) {
    const TrackerFrameStats& s = frames[k].stats;
    out << k << "," << frames[k].stamp << "," << s.tracks_in << "," << s.klt_lost << ","
        << s.forward_backward_rejected << "," << s.ransac_rejected << "," << s.stereo_lost << ","
        << s.disparity_rejected << "," << s.detected << "," << s.new_tracks << "," << s.published
        << "," << s.motion_estimated << "," << s.ms_pyramids << "," << s.ms_temporal << ","
        << s.ms_ransac << "," << s.ms_stereo << "," << s.ms_detect << "," << s.ms_total << ","
        << s.refined << "," << s.refine_failed << "," << s.ms_refine << ","
        << s.exposure_gain_temporal << "," << s.exposure_gain_stereo << "," << s.stereo_converged
        << "," << s.stereo_row_failed << "," << s.stereo_negative_disparity << ","
        << s.stereo_row_offset_px << "," << s.predicted_from_first_matches << "," << s.crowded
        << "," << s.disparity_offset_px << "," << s.disparity_offset_sigma_px << ","
        << s.stereo_roll_deg << "," << s.stereo_roll_sigma_deg << "," << s.stereo_roll_edge_px
        << "," << s.disparity_offset_corrected_px << "," << s.ids_renewed << "\n";
  }
  if (!out) *error = path + ": cannot write";
  return static_cast<bool>(out);
}

PoseTwist poseTwist(const Arguments& args, const KittiSequence& sequence,
                    const std::vector<double>& stamps) {
  PoseTwist result;
  if (sequence.world_T_cam.empty()) return result;
  const size_t n = std::min(stamps.size(), sequence.world_T_cam.size());
  result.cam_T_imu = travelAlignedCamTImu(
      std::vector<Eigen::Matrix4d>(sequence.world_T_cam.begin(), sequence.world_T_cam.begin() + n));
  const Eigen::Matrix4d& cam_T_imu = result.cam_T_imu;
  for (size_t k = 0; k < n; ++k) {
    result.world_T_imu.push_back(sequence.world_T_cam[k] * cam_T_imu);
  }
  twistFromPoses(result.world_T_imu, stamps, args.noise, &result.v, &result.w);
  return result;
}

// What the run gives on stdout: time per frame, the rig check's figures and, with poses, the
// track quality.
void printSummary(const Arguments& args, const KittiSequence& sequence,
                  const std::vector<StereoFrame>& frames, const StereoRigCheck& rig_check,
                  const ProcessingTimes& ms) {
  const size_t T = frames.size();
  std::printf(
      "track_stereo_images: %zu frames -> %s; tracker ms per frame: median %.2f, p99 "
      "%.2f, max %.2f\n",
      T, args.out.c_str(), ms.percentile(0.5), ms.percentile(0.99), ms.max());
  std::printf(
      "stereo rig, last %d frames: disparity offset %.3f px (median of %d fits), row offset "
      "%.3f px, right image's roll %.4f degrees (median of %d fits; rows %.2f px apart at the "
      "side edge)\n",
      std::min<int>(static_cast<int>(T), StereoRigCheck::kWindowPairs),
      rig_check.medianDisparityOffsetPx(), rig_check.disparityOffsetPairs(),
      rig_check.medianRowOffsetPx(), rig_check.medianStereoRollDeg(), rig_check.stereoRollPairs(),
      rig_check.medianRollEdgePx());
  if (T > 0 && frames.back().stats.disparity_offset_corrected_px != 0) {
    const auto corrected = std::count_if(frames.begin(), frames.end(), [](const StereoFrame& f) {
      return f.stats.disparity_offset_corrected_px != 0;
    });
    int renewed = 0;
    for (const StereoFrame& f : frames) renewed += f.stats.ids_renewed;
    std::printf(
        "stereo rig: published right columns moved by the offset in %ld of %zu frames, by %.3f "
        "px in the last (stereo/correct_disparity_offset); %d tracks went on under new ids\n",
        static_cast<long>(corrected), T, frames.back().stats.disparity_offset_corrected_px,
        renewed);
  }
  if (!sequence.world_T_cam.empty()) {
    std::vector<Eigen::Matrix4d> poses(sequence.world_T_cam.begin(),
                                       sequence.world_T_cam.begin() + T);
    std::printf("%s\n",
                evaluateTrackQuality(frames, poses, sequence.calibration, 10).describe().c_str());
  }
}

// The pairs the node would take under input/max_rate_hz (frame_rate_limit.h), as if the folder
// held them alone; decided on the stamps the node would see (times + --time-offset).
void keepFramesDue(const Arguments& args, const TrackerOptions& options, KittiSequence* sequence) {
  const size_t before = sequence->size();
  std::vector<double> stamps(sequence->times);
  for (double& stamp : stamps) stamp += args.time_offset;
  sequence->keepFrames(framesDueForTracking(stamps, options.max_rate_hz));
  if (!args.quiet && sequence->size() < before) {
    std::printf("track_stereo_images: input/max_rate_hz %g: %zu of %zu pairs skipped\n",
                options.max_rate_hz, before - sequence->size(), before);
  }
}

/// Pair k as 8-bit gray (empty images when a file cannot be read): read at the file's depth, a
/// 16-bit png scaled as the node scales mono16 (said on stderr when the scale changes).
void readPair(const KittiSequence& sequence, size_t k, bool quiet, DeepImageScale* image_scale,
              cv::Mat* left, cv::Mat* right) {
  *left = cv::imread(sequence.left_images[k], cv::IMREAD_ANYDEPTH);
  *right = cv::imread(sequence.right_images[k], cv::IMREAD_ANYDEPTH);
  if (left->empty() || right->empty()) return;
  image_scale->scalePair(left, right);
  if (image_scale->changed() && !quiet) {
    std::cerr << "track_stereo_images: " << image_scale->describe() << "\n";
  }
}

int run(int argc, char** argv) {
  Arguments args;
  TrackerOptions options;
  StereoMasks masks;
  KittiSequence sequence;
  std::string error;
  int image_bits = 0;
  if (!parseArguments(argc, argv, &args, &error) ||
      !loadOptions(args.config, &options, &image_bits, &error) ||
      !loadStereoMasks(options, &masks, &error) ||
      !loadKittiSequence(args.left, args.right, args.calib, args.times, args.poses, &sequence,
                         &error, args.cameras)) {
    std::cerr << "track_stereo_images: " << error << "\n";
    return 2;
  }
  if (args.first_frame > 0 && static_cast<size_t>(args.first_frame) + 2 > sequence.size()) {
    std::cerr << "track_stereo_images: --first-frame " << args.first_frame
              << " leaves fewer than 2 of " << sequence.size() << " frames\n";
    return 2;
  }
  sequence.dropFirstFrames(static_cast<size_t>(args.first_frame));
  keepFramesDue(args, options, &sequence);
  const size_t T =
      args.max_frames > 0 ? std::min<size_t>(args.max_frames, sequence.size()) : sequence.size();
  std::vector<double> stamps(T);
  for (size_t k = 0; k < T; ++k) stamps[k] = sequence.times[k] + args.time_offset;
  const PoseTwist pose_twist = poseTwist(args, sequence, stamps);
  std::deque<StampedTwist> twists;
  if (args.predict_with_twist) {
    for (size_t k = 0; k < pose_twist.v.size(); ++k) {
      twists.push_back({stamps[k], pose_twist.v[k], pose_twist.w[k]});
    }
  }
  const Eigen::Matrix4d& cam_T_imu = pose_twist.cam_T_imu;
  StereoTracker tracker(options, sequence.calibration, masks);
  std::vector<StereoFrame> frames;
  ProcessingTimes ms;
  cv::Size image_size;
  bool rig_warned = false;  // the rig check's first hint goes to stderr
  DeepImageScale image_scale(image_bits);
  for (size_t k = 0; k < T; ++k) {
    cv::Mat left, right;
    readPair(sequence, k, args.quiet, &image_scale, &left, &right);
    StereoFrame frame;
    std::optional<CameraMotionPrior> prior;
    if (args.predict_with_twist && k > 0) {
      prior = motionPriorFromTwists(twists, cam_T_imu, stamps[k - 1], stamps[k]);
    }
    if (left.empty() || right.empty() ||
        !tracker.process(left, right, stamps[k], prior ? &*prior : nullptr, &frame, &error)) {
      std::cerr << "track_stereo_images: frame " << k << " (" << sequence.left_images[k]
                << "): " << (left.empty() || right.empty() ? "cannot read the image" : error)
                << "\n";
      return 1;
    }
    image_size = left.size();
    ms.add(frame.stats.ms_total);
    if (const std::string hint = tracker.rigCheck().hint(); !rig_warned && !hint.empty()) {
      std::cerr << "track_stereo_images: warning from frame " << k << ": " << hint << "\n";
      rig_warned = true;
    }
    if (!args.debug_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "/%06zu.png", k);
      cv::imwrite(args.debug_dir + name, drawStereoTracks(left, right, frame, masks));
    }
    frames.push_back(std::move(frame));
  }
  if (!writeDataset(args, sequence, frames, pose_twist, image_size, &error) ||
      (!args.stats.empty() && !writeStats(args.stats, frames, &error))) {
    std::cerr << "track_stereo_images: " << error << "\n";
    return 1;
  }
  if (!args.quiet) printSummary(args, sequence, frames, tracker.rigCheck(), ms);
  return 0;
}

}  // namespace
}  // namespace ekf_vislam

int main(int argc, char** argv) { return ekf_vislam::run(argc, argv); }
