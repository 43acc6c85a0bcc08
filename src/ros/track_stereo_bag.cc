// track_stereo_bag: the stereo tracker over a recorded bag, without a roscore. It reads the
// rectified image pairs, their camera_info, the twist and /tf_static in bag order, tracks each
// pair as stereo_tracker_node does live (the same options, the same wait for the twist that
// reaches a pair's stamp, the same motion prior) and writes a bag of every message but the
// images, plus stereo/features. vislam_offline takes that bag:
//
//   rosrun ekf_vislam track_stereo_bag --bag robot.bag --out features.bag [--config tracker.yaml]
//   rosrun ekf_vislam vislam_offline --bag features.bag --out DIR
#include "ekf_vislam/core/median.h"
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/ros/bag_stereo_tracker.h"
#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/tracker_options.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <map>
#include <string>
#include <vector>

namespace {

using namespace ekf_vislam;

const char* kUsage =
    "usage: track_stereo_bag --bag IN.bag --out OUT.bag [--config tracker.yaml] [--no-twist]\n"
    "                        [--rectify] [--debug-dir DIR] [--left-topic T] [--right-topic T]\n"
    "                        [--left-info-topic T] [--right-info-topic T] [--twist-topic T]\n"
    "                        [--features-topic T]\n"
    "Tracks the rectified stereo pairs of a bag as stereo_tracker_node does live and writes\n"
    "OUT.bag: every message of IN.bag but the images, plus the features (StereoFeatureArray on\n"
    "--features-topic, default /stereo/features), each written where the node would have\n"
    "published it (after the twist that reaches its pair's stamp). `vislam_offline --bag\n"
    "OUT.bag` then runs the estimator. Topics default to those of stereo_vislam.launch\n"
    "(/stereo/left/image_rect, /stereo/right/image_rect, /stereo/{left,right}/camera_info,\n"
    "/imu/twist: TwistStamped, TwistWithCovarianceStamped or Odometry); the twist's frame is\n"
    "found in /tf_static. --config: config/tracker.yaml's keys (absent: the defaults), the ros/\n"
    "group included (max_stamp_difference, use_twist; --no-twist sets use_twist false).\n"
    "--debug-dir: the debug drawing of every tracked pair as DIR/NNNNNN.png (stereo/debug_image).\n"
    "Images: sensor_msgs/Image (mono8, bgr8, rgb8...) or sensor_msgs/CompressedImage (png,\n"
    "jpeg: decoded as image_transport's compressed subscriber decodes them; give the topic,\n"
    "e.g. --left-topic /stereo/left/image_rect/compressed).\n"
    "--rectify (ros/rectify): the images are raw, rectified with their camera_info's K, D, R and\n"
    "P as the node rectifies them; the topics then default to /stereo/{left,right}/image_raw.\n";

struct Arguments {
  std::string bag, out, config, debug_dir;
  bool no_twist = false, rectify = false;
  bool given_image_topic = false;  ///< --left-topic or --right-topic
  BagTrackerTopics topics;
};

bool parseArguments(int argc, char** argv, Arguments* args, std::string* error) {
  const std::map<std::string, std::string*> values = {
      {"--bag", &args->bag},
      {"--out", &args->out},
      {"--config", &args->config},
      {"--debug-dir", &args->debug_dir},
      {"--left-topic", &args->topics.left},
      {"--right-topic", &args->topics.right},
      {"--left-info-topic", &args->topics.left_info},
      {"--right-info-topic", &args->topics.right_info},
      {"--twist-topic", &args->topics.twist},
      {"--features-topic", &args->topics.features}};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = values.find(arg);
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--no-twist") {
      args->no_twist = true;
    } else if (arg == "--rectify") {
      args->rectify = true;
    } else if (value != values.end() && i + 1 < argc) {
      *value->second = argv[++i];
      if (arg == "--left-topic" || arg == "--right-topic") args->given_image_topic = true;
    } else {
      *error = "unknown or incomplete argument " + arg;
      return false;
    }
  }
  if (args->bag.empty() || args->out.empty()) *error = "--bag and --out are required";
  return error->empty();
}

bool loadOptions(const Arguments& args, TrackerOptions* options,
                 StereoTrackerRosOptions* ros_options, std::string* error) {
  if (!args.config.empty()) {
    YamlParameterSource source(args.config);
    if (!source.ok()) {
      *error = source.error();
      return false;
    }
    if (!parseTrackerOptions(source, options, error) ||
        !parseTrackerRosOptions(source, ros_options, error)) {
      return false;
    }
    const std::string unknown = unknownTrackerKeys(source);
    if (!unknown.empty())
      std::cerr << "track_stereo_bag: " << args.config << ": " << unknown << "\n";
  }
  if (args.no_twist) ros_options->use_twist = false;
  if (args.rectify) ros_options->rectify = true;
  *error = options->validate();
  return error->empty();
}

/// The image topics hold sensor_msgs/Image or CompressedImage; *has_twist: the bag has the twist
/// topic.
bool checkTopics(const Arguments& args, rosbag::View& view, bool* has_twist, std::string* error) {
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) types[c->topic] = c->datatype;
  *has_twist = types.count(args.topics.twist) > 0;
  for (const std::string& topic : {args.topics.left, args.topics.right}) {
    const auto type = types.find(topic);
    if (type == types.end()) {
      std::string images;
      for (const auto& [name, datatype] : types) {
        if (datatype.rfind("sensor_msgs/", 0) == 0 && datatype.find("Image") != std::string::npos)
          images += " " + name + " (" + datatype + ")";
      }
      *error = "no " + topic + " (--left-topic, --right-topic); its image topics:" +
               (images.empty() ? std::string(" none") : images);
      return false;
    }
    if (type->second != "sensor_msgs/Image" && type->second != "sensor_msgs/CompressedImage") {
      *error = topic + " holds " + type->second + ", not sensor_msgs/Image or CompressedImage";
      return false;
    }
  }
  return true;
}

int run(int argc, char** argv) {
  Arguments args;
  TrackerOptions options;
  StereoTrackerRosOptions ros_options;
  StereoMasks masks;
  std::string error;
  if (!parseArguments(argc, argv, &args, &error) ||
      !loadOptions(args, &options, &ros_options, &error) ||
      !loadStereoMasks(options, &masks, &error)) {
    std::cerr << "track_stereo_bag: " << error << "\n" << kUsage;
    return 2;
  }
  if (ros_options.rectify && !args.given_image_topic) {  // the node's topics with ros/rectify
    args.topics.left = "/stereo/left/image_raw";
    args.topics.right = "/stereo/right/image_raw";
  }
  rosbag::Bag in(args.bag, rosbag::bagmode::Read);
  rosbag::View view(in);
  bool has_twist = false;
  if (!checkTopics(args, view, &has_twist, &error)) {
    std::cerr << "track_stereo_bag: " << args.bag << ": " << error << "\n";
    return 2;
  }
  rosbag::Bag out(args.out, rosbag::bagmode::Write);
  BagStereoTracker tracker(args.topics, options, ros_options, masks, has_twist, args.debug_dir,
                           &out);
  for (const rosbag::MessageInstance& m : view) tracker.add(m);
  tracker.finish();
  out.close();
  const BagTrackingCounts& c = tracker.counts();
  std::cout << "track_stereo_bag: " << c.left << " left and " << c.right << " right images, "
            << c.unpaired << " without a partner, " << c.unsynchronized
            << " pairs further apart than ros/max_stamp_difference, " << c.undecodable
            << " not decodable; " << c.tracked << " pairs tracked (" << c.twist_predicted
            << " predicted from the twist, " << c.without_features << " without a feature), "
            << c.refused << " refused, " << c.no_camera_info << " dropped without camera_info, "
            << c.time_jump_resets << " restarts (time went back); observations per pair "
            << (c.tracked ? static_cast<double>(c.observations) / c.tracked : 0.0) << " -> "
            << args.out << "\n";
  if (!c.rectify_ms.empty()) {
    std::vector<double> ms = c.rectify_ms;
    std::cout << "track_stereo_bag: rectification (ros/rectify) per pair: median " << median(&ms)
              << " ms, max " << *std::max_element(ms.begin(), ms.end()) << " ms (the first pair's "
              << c.rectify_ms.front() << " ms includes making the maps)\n";
  }
  if (c.tracked == 0) {
    std::cerr << "track_stereo_bag: no pair tracked"
              << (c.no_camera_info > 0 ? ": the bag has no camera_info pair on --left-info-topic "
                                         "and --right-info-topic"
                                       : "")
              << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "track_stereo_bag: " << e.what() << std::endl;
    return 1;
  }
}
