#include "ekf_vislam/tracker/kitti_sequence.h"

#include "ekf_vislam/core/calibration_builder.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <type_traits>

namespace ekf_vislam {

void KittiSequence::dropFirstFrames(size_t n) {
  std::vector<size_t> rest;
  for (size_t k = n; k < size(); ++k) rest.push_back(k);
  keepFrames(rest);
}

void KittiSequence::keepFrames(const std::vector<size_t>& indices) {
  auto keep = [&indices](auto* items) {
    if (items->empty()) return;  // poses are optional
    auto kept = std::remove_reference_t<decltype(*items)>();
    kept.reserve(indices.size());
    for (const size_t k : indices) kept.push_back((*items)[k]);
    *items = std::move(kept);
  };
  keep(&left_images);
  keep(&right_images);
  keep(&times);
  keep(&world_T_cam);
}

namespace {

// Numbers of one line (a leading "NAME:" label is skipped); false on a non-number.
bool parseNumbers(const std::string& line, std::vector<double>* numbers, std::string* label) {
  std::istringstream in(line);
  std::string token;
  numbers->clear();
  label->clear();
  while (in >> token) {
    if (numbers->empty() && label->empty() && token.back() == ':') {
      *label = token.substr(0, token.size() - 1);
      continue;
    }
    try {
      size_t used = 0;
      const double value = std::stod(token, &used);
      if (used != token.size() || !std::isfinite(value)) return false;
      numbers->push_back(value);
    } catch (const std::exception&) {
      return false;
    }
  }
  return true;
}

bool openFile(const std::string& path, std::ifstream* in, std::string* error) {
  in->open(path);
  if (!*in) {
    *error = path + ": cannot open";
    return false;
  }
  return true;
}

}  // namespace

bool readKittiCalibration(const std::string& path, StereoCalibration* calibration,
                          std::string* error, KittiCameras cameras, Eigen::Matrix4d* cam0_T_left) {
  std::ifstream in;
  if (!openFile(path, &in, error)) return false;
  std::map<std::string, std::vector<double>> labelled;
  std::vector<std::vector<double>> unlabeled;
  std::vector<double> numbers;
  std::string line, label;
  while (std::getline(in, line)) {
    if (!parseNumbers(line, &numbers, &label)) {
      *error = path + ": not a line of numbers: " + line.substr(0, 60);
      return false;
    }
    if (numbers.empty()) continue;
    if (label.empty()) {
      unlabeled.push_back(numbers);
    } else {
      labelled[label] = numbers;
    }
  }
  const std::string left_label = "P" + std::to_string(cameras.left);
  const std::string right_label = "P" + std::to_string(cameras.right);
  std::vector<double> pl = labelled[left_label], pr = labelled[right_label];
  if (cameras.left == 0 && cameras.right == 1) {  // a file of two unlabelled lines
    if (pl.empty() && unlabeled.size() >= 1) pl = unlabeled[0];
    if (pr.empty() && unlabeled.size() >= 2) pr = unlabeled[1];
  }
  if (pl.size() != 12 || pr.size() != 12) {
    *error = path + ": needs two 3x4 projection matrices " + left_label + " and " + right_label +
             " (12 numbers each)";
    return false;
  }
  // The estimator's rule (stereoIntrinsicsFromProjections): a rectified pair, equal intrinsics;
  // the right camera's translation taken relative to the left one's.
  const PinholeProjection left{pl[0], pl[5], pl[2], pl[6], 0.0};
  const PinholeProjection right{pr[0], pr[5], pr[2], pr[6], pr[3] - pl[3]};
  std::string why;
  if (!stereoIntrinsicsFromProjections(left, right, calibration, &why)) {
    *error = path + ": " + left_label + " and " + right_label + ": " + why;
    return false;
  }
  if (cam0_T_left != nullptr) {
    // P<left> = K [I | t], t = K^-1 P<left>[:, 3]: camera 0's origin in the left camera's frame.
    const double tz = pl[11];
    const Eigen::Vector3d t((pl[3] - pl[2] * tz) / pl[0], (pl[7] - pl[6] * tz) / pl[5], tz);
    cam0_T_left->setIdentity();
    cam0_T_left->topRightCorner<3, 1>() = -t;
  }
  return true;
}

bool readKittiTimes(const std::string& path, std::vector<double>* times, std::string* error) {
  std::ifstream in;
  if (!openFile(path, &in, error)) return false;
  times->clear();
  std::vector<double> numbers;
  std::string line, label;
  while (std::getline(in, line)) {
    if (!parseNumbers(line, &numbers, &label) || numbers.size() > 1) {
      *error = path + ": expected one time per line: " + line.substr(0, 60);
      return false;
    }
    if (numbers.empty()) continue;
    if (!times->empty() && numbers[0] <= times->back()) {
      *error = path + ": times must increase (line " + std::to_string(times->size() + 1) + ")";
      return false;
    }
    times->push_back(numbers[0]);
  }
  return true;
}

bool readKittiPoses(const std::string& path, std::vector<Eigen::Matrix4d>* poses,
                    std::string* error) {
  std::ifstream in;
  if (!openFile(path, &in, error)) return false;
  poses->clear();
  std::vector<double> numbers;
  std::string line, label;
  while (std::getline(in, line)) {
    if (!parseNumbers(line, &numbers, &label) || (!numbers.empty() && numbers.size() != 12)) {
      *error = path + ": expected 12 numbers (3x4 row-major) per line: " + line.substr(0, 60);
      return false;
    }
    if (numbers.empty()) continue;
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) T(r, c) = numbers[4 * r + c];
    }
    poses->push_back(T);
  }
  return true;
}

bool listImages(const std::string& folder, std::vector<std::string>* paths, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    *error = folder + ": not a folder";
    return false;
  }
  paths->clear();
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".ppm") {
      paths->push_back(entry.path().string());
    }
  }
  std::sort(paths->begin(), paths->end());
  if (paths->empty()) {
    *error = folder + ": no images (.png, .jpg, .pgm, .ppm)";
    return false;
  }
  return true;
}

KittiFolder kittiFolderParts(const std::string& folder, KittiCameras cameras) {
  namespace fs = std::filesystem;
  const fs::path root(folder);
  std::error_code ec;
  KittiFolder parts;
  // Either folder of the own layout chooses it, so that a missing one is named.
  const bool own_layout =
      cameras.left == 0 && cameras.right == 1 &&
      (fs::is_directory(root / "image_left", ec) || fs::is_directory(root / "image_right", ec));
  parts.left =
      (root / (own_layout ? "image_left" : "image_" + std::to_string(cameras.left))).string();
  parts.right =
      (root / (own_layout ? "image_right" : "image_" + std::to_string(cameras.right))).string();
  parts.calib = (root / "calib.txt").string();
  parts.times = (root / "times.txt").string();
  if (fs::is_regular_file(root / "poses.txt", ec)) parts.poses = (root / "poses.txt").string();
  return parts;
}

bool loadKittiSequence(const std::string& left_folder, const std::string& right_folder,
                       const std::string& calib_path, const std::string& times_path,
                       const std::string& poses_path, KittiSequence* sequence, std::string* error,
                       KittiCameras cameras) {
  Eigen::Matrix4d cam0_T_left;
  if (!listImages(left_folder, &sequence->left_images, error) ||
      !listImages(right_folder, &sequence->right_images, error) ||
      !readKittiCalibration(calib_path, &sequence->calibration, error, cameras, &cam0_T_left) ||
      !readKittiTimes(times_path, &sequence->times, error)) {
    return false;
  }
  sequence->world_T_cam.clear();
  if (!poses_path.empty() && !readKittiPoses(poses_path, &sequence->world_T_cam, error)) {
    return false;
  }
  for (Eigen::Matrix4d& world_T_cam : sequence->world_T_cam)
    world_T_cam = world_T_cam * cam0_T_left;
  const size_t n = sequence->left_images.size();
  if (sequence->right_images.size() != n || sequence->times.size() != n ||
      (!poses_path.empty() && sequence->world_T_cam.size() != n)) {
    *error =
        "frame counts differ: " + std::to_string(n) + " left images, " +
        std::to_string(sequence->right_images.size()) + " right images, " +
        std::to_string(sequence->times.size()) + " times" +
        (poses_path.empty() ? "" : ", " + std::to_string(sequence->world_T_cam.size()) + " poses");
    return false;
  }
  return true;
}

}  // namespace ekf_vislam
