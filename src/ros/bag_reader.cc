#include "ekf_vislam/ros/bag_reader.h"

#include "ekf_vislam/ros/conversions.h"

#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <exception>

namespace ekf_vislam {

BagReader::BagReader() = default;
BagReader::~BagReader() = default;

bool BagReader::open(const std::string& path, const BagTopics& topics, std::string* error) {
  topics_ = topics;
  try {
    bag_ = std::make_unique<rosbag::Bag>();
    bag_->open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    bag_.reset();
    if (error) *error = "cannot read bag " + path + ": " + e.what();
    return false;
  }
  return true;
}

uint32_t BagReader::messageCount(const std::string& topic) const {
  if (!bag_) return 0;
  rosbag::View view(*bag_, rosbag::TopicQuery(topic));
  return view.size();
}

std::string BagReader::dataType(const std::string& topic) const {
  if (!bag_) return "";
  rosbag::View view(*bag_, rosbag::TopicQuery(topic));
  for (const rosbag::ConnectionInfo* info : view.getConnections()) return info->datatype;
  return "";
}

bool BagReader::readCalibrationData(BagCalibrationData* data, std::string* error) {
  *data = BagCalibrationData();
  try {
    {
      rosbag::View view(*bag_, rosbag::TopicQuery(std::vector<std::string>{topics_.left_info,
                                                                           topics_.right_info}));
      for (const rosbag::MessageInstance& m : view) {
        auto info = m.instantiate<sensor_msgs::CameraInfo>();
        if (!info) {
          if (error) *error = m.getTopic() + " is not sensor_msgs/CameraInfo";
          return false;
        }
        if (m.getTopic() == topics_.left_info && !data->has_left_info) {
          data->left_info = *info;
          data->has_left_info = true;
        } else if (m.getTopic() == topics_.right_info && !data->has_right_info) {
          data->right_info = *info;
          data->has_right_info = true;
        }
        if (data->has_left_info && data->has_right_info) break;
      }
    }
    {
      rosbag::View view(*bag_, rosbag::TopicQuery(topics_.tf_static));
      for (const rosbag::MessageInstance& m : view) {
        auto tf = m.instantiate<tf2_msgs::TFMessage>();
        if (!tf) {
          if (error) *error = topics_.tf_static + " is not tf2_msgs/TFMessage";
          return false;
        }
        data->static_transforms.insert(data->static_transforms.end(), tf->transforms.begin(),
                                       tf->transforms.end());
      }
    }
    {
      rosbag::View view(*bag_, rosbag::TopicQuery(topics_.features));
      for (const rosbag::MessageInstance& m : view) {
        auto features = m.instantiate<ekf_vislam::StereoFeatureArray>();
        if (features) data->camera_frame = features->header.frame_id;
        break;
      }
    }
  } catch (const std::exception& e) {
    if (error) *error = std::string("cannot read the calibration from the bag: ") + e.what();
    return false;
  }
  if (data->camera_frame.empty() && data->has_left_info) {
    data->camera_frame = data->left_info.header.frame_id;
  }
  return true;
}

void BagReader::setTwistFrames(
    const std::string& imu_frame,
    const std::vector<geometry_msgs::TransformStamped>& static_transforms) {
  imu_frame_ = imu_frame;
  static_transforms_ = static_transforms;
  imu_T_child_frame_.clear();
}

bool BagReader::convertTwist(const rosbag::MessageInstance& m, TwistData* twist,
                             std::string* error) {
  if (auto stamped = m.instantiate<geometry_msgs::TwistStamped>()) {
    *twist = ros_conversions::toTwistData(*stamped);
    return true;
  }
  if (auto with_covariance = m.instantiate<geometry_msgs::TwistWithCovarianceStamped>()) {
    *twist = ros_conversions::toTwistData(*with_covariance);
    return true;
  }
  auto odometry = m.instantiate<nav_msgs::Odometry>();
  if (!odometry) {
    if (error) *error = topics_.twist + " holds " + m.getDataType() + ", not a twist type";
    return false;
  }
  const std::string child =
      odometry->child_frame_id.empty() ? imu_frame_ : odometry->child_frame_id;
  if (child != imu_T_child_frame_) {
    imu_T_child_.setIdentity();
    if (child != imu_frame_ &&
        !lookupStaticTransform(static_transforms_, imu_frame_, child, &imu_T_child_, error)) {
      return false;
    }
    imu_T_child_frame_ = child;
  }
  *twist = ros_conversions::toTwistData(*odometry, imu_T_child_);
  return true;
}

bool BagReader::forEachMeasurement(const Callback& callback, std::string* error) {
  try {
    rosbag::View view(
        *bag_, rosbag::TopicQuery(std::vector<std::string>{topics_.twist, topics_.features}));
    const double begin = view.getBeginTime().toSec();
    const double span = std::max(1e-9, view.getEndTime().toSec() - begin);
    for (const rosbag::MessageInstance& m : view) {
      const double fraction = (m.getTime().toSec() - begin) / span;
      if (m.getTopic() == topics_.twist) {
        TwistData twist;
        if (!convertTwist(m, &twist, error)) return false;
        callback(Measurement(twist), fraction);
      } else {
        auto features = m.instantiate<ekf_vislam::StereoFeatureArray>();
        if (!features) {
          if (error) *error = topics_.features + " is not ekf_vislam/StereoFeatureArray";
          return false;
        }
        callback(Measurement(ros_conversions::toFeatureFrame(*features)), fraction);
      }
    }
  } catch (const std::exception& e) {
    if (error) *error = std::string("cannot read the bag: ") + e.what();
    return false;
  }
  return true;
}

bool lookupStaticTransform(const std::vector<geometry_msgs::TransformStamped>& transforms,
                           const std::string& target_frame, const std::string& source_frame,
                           Eigen::Isometry3d* target_T_source, std::string* error) {
  tf2::BufferCore buffer;
  for (const geometry_msgs::TransformStamped& t : transforms) {
    try {
      buffer.setTransform(t, "bag", true);
    } catch (const std::exception&) {
      // tf2 logs bad transforms; the lookup below reports what is missing.
    }
  }
  try {
    const geometry_msgs::TransformStamped t =
        buffer.lookupTransform(target_frame, source_frame, ros::Time(0));
    *target_T_source = ros_conversions::toIsometry(t.transform);
  } catch (const tf2::TransformException& e) {
    if (error)
      *error = "no static transform " + target_frame + " -> " + source_frame + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace ekf_vislam
