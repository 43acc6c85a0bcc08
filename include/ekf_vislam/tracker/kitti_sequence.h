// A stereo image folder in the KITTI odometry layout: left and right image folders (sorted
// file names pair up), calib.txt (P0 and P1, 3x4 row-major, optionally prefixed "P0:"; KITTI's
// own files also hold P2 and P3, the colour cameras), times.txt (one time per frame, s) and
// optionally poses.txt (world_T_cam0, 3x4 row-major per line). No ROS.
#pragma once

#include "ekf_vislam/tracker/tracker_types.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace ekf_vislam {

/// Which projections of calib.txt are the left and right images': P<left> and P<right>. The
/// default, 0 and 1, also takes a file of two unlabelled lines.
struct KittiCameras {
  int left = 0;
  int right = 1;
};

struct KittiSequence {
  std::vector<std::string> left_images, right_images;  ///< paths, sorted
  std::vector<double> times;                           ///< s, one per frame
  StereoCalibration calibration;
  std::vector<Eigen::Matrix4d> world_T_cam;  ///< the left camera's (empty without poses)
  size_t size() const { return times.size(); }
  /// Leaves out the first n frames (images, times, poses); all of them when n >= size().
  void dropFirstFrames(size_t n);
  /// Keeps the frames at `indices` (increasing, each < size()), in that order.
  void keepFrames(const std::vector<size_t>& indices);
};

/// Reads the calibration of the pair `cameras` (fx, fy, cx, cy from P<left>; baseline =
/// (P<left>[0,3] - P<right>[0,3]) / fx) and, when cam0_T_left is given, where the left camera
/// sits against camera 0 (the frame of KITTI's poses): P<left> = K [I | t] puts it at -t.
bool readKittiCalibration(const std::string& path, StereoCalibration* calibration,
                          std::string* error, KittiCameras cameras = {},
                          Eigen::Matrix4d* cam0_T_left = nullptr);
/// One number per line.
bool readKittiTimes(const std::string& path, std::vector<double>* times, std::string* error);
/// One 3x4 row-major matrix per line.
bool readKittiPoses(const std::string& path, std::vector<Eigen::Matrix4d>* poses,
                    std::string* error);
/// Image files (.png, .jpg, .pgm, .ppm) of a folder, sorted by name.
bool listImages(const std::string& folder, std::vector<std::string>* paths, std::string* error);

/// Where a sequence folder keeps its parts: image_left/ and image_right/ (the layout of the
/// package's tools and clips) when either is there and `cameras` are 0 and 1, else KITTI's own
/// image_<left>/ and image_<right>/ (image_0/ and image_1/, or image_2/ and image_3/ for the
/// colour cameras); calib.txt, times.txt, and poses.txt when there is one (else empty: KITTI
/// keeps its poses apart, in poses/NN.txt).
struct KittiFolder {
  std::string left, right, calib, times, poses;
};
KittiFolder kittiFolderParts(const std::string& folder, KittiCameras cameras = {});

/// Everything together; checks that the counts agree (poses_path may be empty). The poses
/// (camera 0's) are turned into the left camera's of `cameras`.
bool loadKittiSequence(const std::string& left_folder, const std::string& right_folder,
                       const std::string& calib_path, const std::string& times_path,
                       const std::string& poses_path, KittiSequence* sequence, std::string* error,
                       KittiCameras cameras = {});

}  // namespace ekf_vislam
