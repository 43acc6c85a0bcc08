// A stereo image folder in the KITTI odometry layout: left and right image folders (sorted
// file names pair up), calib.txt (P0 and P1, 3x4 row-major, optionally prefixed "P0:"),
// times.txt (one time per frame, s) and optionally poses.txt (world_T_cam0, 3x4 row-major per
// line). No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace ekf_vislam {

struct KittiSequence {
  std::vector<std::string> left_images, right_images;  ///< paths, sorted
  std::vector<double> times;                           ///< s, one per frame
  StereoCalibration calibration;
  std::vector<Eigen::Matrix4d> world_T_cam;  ///< empty without poses
  size_t size() const { return times.size(); }
  /// Leaves out the first n frames (images, times, poses); all of them when n >= size().
  void dropFirstFrames(size_t n);
  /// Keeps the frames at `indices` (increasing, each < size()), in that order.
  void keepFrames(const std::vector<size_t>& indices);
};

/// Reads the calibration (fx, fy, cx, cy from P0; baseline = (P0[0,3] - P1[0,3]) / fx).
bool readKittiCalibration(const std::string& path, StereoCalibration* calibration,
                          std::string* error);
/// One number per line.
bool readKittiTimes(const std::string& path, std::vector<double>* times, std::string* error);
/// One 3x4 row-major matrix per line.
bool readKittiPoses(const std::string& path, std::vector<Eigen::Matrix4d>* poses,
                    std::string* error);
/// Image files (.png, .jpg, .pgm, .ppm) of a folder, sorted by name.
bool listImages(const std::string& folder, std::vector<std::string>* paths, std::string* error);

/// Everything together; checks that the counts agree (poses_path may be empty).
bool loadKittiSequence(const std::string& left_folder, const std::string& right_folder,
                       const std::string& calib_path, const std::string& times_path,
                       const std::string& poses_path, KittiSequence* sequence, std::string* error);

}  // namespace ekf_vislam
