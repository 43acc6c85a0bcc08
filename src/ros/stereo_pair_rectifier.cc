#include "ekf_vislam/ros/stereo_pair_rectifier.h"

#include "ekf_vislam/ros/conversions.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>

namespace ekf_vislam {

RawCameraModel rawCameraModel(const sensor_msgs::CameraInfo& full) {
  const sensor_msgs::CameraInfo info = ros_conversions::cameraInfoOfImage(full);
  RawCameraModel model;
  model.width = static_cast<int>(info.width);
  model.height = static_cast<int>(info.height);
  model.distortion_model = info.distortion_model;
  model.D = info.D;
  std::copy(info.K.begin(), info.K.end(), model.K.begin());
  std::copy(info.R.begin(), info.R.end(), model.R.begin());
  std::copy(info.P.begin(), info.P.end(), model.P.begin());
  return model;
}

StereoPairRectifier::Result StereoPairRectifier::rectify(
    const sensor_msgs::CameraInfo& left_info, const sensor_msgs::CameraInfo& right_info,
    cv::Mat* left, cv::Mat* right, std_msgs::Header* header,
    std::optional<geometry_msgs::TransformStamped>* new_transform, std::string* why) {
  const auto start = std::chrono::steady_clock::now();
  const char* sides[2] = {"left", "right"};
  ImageRectifier* rectifiers[2] = {&left_, &right_};
  const sensor_msgs::CameraInfo* infos[2] = {&left_info, &right_info};
  cv::Mat* images[2] = {left, right};
  cv::Mat rectified[2];
  for (int side = 0; side < 2; ++side) {
    const RawCameraModel model = rawCameraModel(*infos[side]);
    if (!rectifiers[side]->ready() || rectifiers[side]->model() != model) {
      std::string error;
      if (!rectifiers[side]->reset(model, &error)) {
        *why = std::string(sides[side]) + " camera_info refused for ros/rectify: " + error;
        return Result::kCameraInfoRefused;
      }
      if (side == 0) new_left_model_ = true;
    }
    // The gray images are 8-bit: rectify() refuses only a size other than the camera_info's.
    if (!rectifiers[side]->rectify(*images[side], &rectified[side])) {
      const RawCameraModel& expected = rectifiers[side]->model();
      *why = std::string(sides[side]) + " image size " + std::to_string(images[side]->cols) + "x" +
             std::to_string(images[side]->rows) + " differs from its camera_info's, " +
             std::to_string(expected.width) + "x" + std::to_string(expected.height) +
             " (binning and roi applied)";
      return Result::kSizeMismatch;
    }
  }
  *left = rectified[0];
  *right = rectified[1];
  const std::string frame = header->frame_id.empty() ? left_info.header.frame_id : header->frame_id;
  new_transform->reset();
  if (new_left_model_ || frame != rectified_from_frame_) {
    *new_transform = leftTransform(frame);
    (*new_transform)->header.stamp = header->stamp;
    new_left_model_ = false;
    rectified_from_frame_ = frame;
  }
  header->frame_id = rectifiedFrame(frame);
  rectify_ms_last_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return Result::kOk;
}

std::string StereoPairRectifier::rectifiedFrame(const std::string& frame) {
  return frame + "_rect";
}

geometry_msgs::TransformStamped StereoPairRectifier::leftTransform(const std::string& frame) const {
  // R turns raw camera coordinates into rectified ones (x_rect = R x_cam): the rectified frame's
  // axes in the camera's frame are the rows of R, its rotation R^T.
  const auto& R = left_.model().R;
  Eigen::Matrix3d rect_R_cam;
  rect_R_cam << R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8];
  const Eigen::Quaterniond cam_q_rect(rect_R_cam.transpose());
  geometry_msgs::TransformStamped t;
  t.header.frame_id = frame;
  t.child_frame_id = rectifiedFrame(frame);
  t.transform.rotation.w = cam_q_rect.w();
  t.transform.rotation.x = cam_q_rect.x();
  t.transform.rotation.y = cam_q_rect.y();
  t.transform.rotation.z = cam_q_rect.z();
  return t;
}

}  // namespace ekf_vislam
