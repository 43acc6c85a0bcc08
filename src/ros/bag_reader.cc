#include "ekf_vislam/ros/bag_reader.h"

#include "ekf_vislam/ros/conversions.h"

#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
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
        const bool left = m.getTopic() == topics_.left_info;
        bool& has_first = left ? data->has_left_info : data->has_right_info;
        sensor_msgs::CameraInfo& first = left ? data->left_info : data->right_info;
        if (!has_first) {
          first = *info;
          has_first = true;
        } else if (!sameProjection(ros_conversions::projectionOf(*info),
                                   ros_conversions::projectionOf(first))) {
          ++data->camera_info_changed;
        }
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

namespace {

/// A tf buffer holding these static transforms (bad ones are left out: tf2 logs them, and a
/// lookup then says what is missing).
std::unique_ptr<tf2::BufferCore> staticBuffer(
    const std::vector<geometry_msgs::TransformStamped>& transforms) {
  auto buffer = std::make_unique<tf2::BufferCore>();
  for (const geometry_msgs::TransformStamped& t : transforms) {
    try {
      buffer->setTransform(t, "bag", true);
    } catch (const std::exception&) {
    }
  }
  return buffer;
}

}  // namespace

void BagReader::setTwistFrames(
    const std::string& imu_frame,
    const std::vector<geometry_msgs::TransformStamped>& static_transforms) {
  static_tf_ = staticBuffer(static_transforms);
  imu_T_frame_ = FixedFrameTransforms(static_tf_.get(), imu_frame);
}

void BagReader::useTwistCombiner(const TwistCombinerOptions& options, double time_jump_reset) {
  combiner_ = std::make_unique<TwistCombiner>(options);
  combiner_time_jumps_ = TimeJumpDetector(time_jump_reset, 2);
}

bool BagReader::imuTFrame(const std::string& frame, Eigen::Isometry3d* imu_T_frame,
                          std::string* error) {
  std::string why;
  if (imu_T_frame_.lookup(frame, imu_T_frame, &why)) return true;
  if (error)
    *error = "no static transform " + imu_T_frame_.bodyFrame() + " -> " + frame + ": " + why;
  return false;
}

bool BagReader::readImu(const rosbag::MessageInstance& m, const Callback& callback, double fraction,
                        std::string* error) {
  auto imu = m.instantiate<sensor_msgs::Imu>();
  if (!imu) {
    if (error) *error = topics_.imu_data + " is not sensor_msgs/Imu";
    return false;
  }
  Eigen::Isometry3d imu_T_frame;
  if (!imuTFrame(imu->header.frame_id, &imu_T_frame, error)) return false;
  if (accelerometer_) {
    if (const std::optional<AccelerometerData> sample =
            ros_conversions::toAccelerometerData(*imu, imu_T_frame)) {
      callback(Measurement(*sample), fraction);
    }
  }
  if (combiner_) {
    if (combiner_time_jumps_.jumpedBack(0, imu->header.stamp.toSec())) combiner_->reset();
    combiner_->addAngularVelocity(
        ros_conversions::toAngularVelocitySample(*imu, imu_T_frame.linear()));
    for (TwistData& twist : combiner_->takeReady()) callback(Measurement(twist), fraction);
  }
  return true;
}

bool BagReader::readWheelOdometry(const rosbag::MessageInstance& m, const Callback& callback,
                                  double fraction, std::string* error) {
  auto odometry = m.instantiate<nav_msgs::Odometry>();
  if (!odometry) {
    if (error) *error = topics_.wheel_odometry + " is not nav_msgs/Odometry";
    return false;
  }
  if (combiner_time_jumps_.jumpedBack(1, odometry->header.stamp.toSec())) combiner_->reset();
  Eigen::Isometry3d imu_T_frame;
  if (!imuTFrame(odometry->child_frame_id, &imu_T_frame, error)) return false;
  combiner_->addLinearVelocity(ros_conversions::toLinearVelocitySample(*odometry, imu_T_frame));
  for (TwistData& twist : combiner_->takeReady()) callback(Measurement(twist), fraction);
  return true;
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
  Eigen::Isometry3d imu_T_child;
  if (!imuTFrame(odometry->child_frame_id, &imu_T_child, error)) return false;
  *twist = ros_conversions::toTwistData(*odometry, imu_T_child);
  return true;
}

bool BagReader::forEachMeasurement(const Callback& callback, std::string* error) {
  try {
    const std::vector<std::string> twist_topics =
        combiner_ ? std::vector<std::string>{topics_.imu_data, topics_.wheel_odometry}
                  : std::vector<std::string>{topics_.twist};
    std::vector<std::string> read = twist_topics;
    read.push_back(topics_.features);
    if (accelerometer_ && !combiner_) read.push_back(topics_.imu_data);
    rosbag::View view(*bag_, rosbag::TopicQuery(read));
    const double begin = view.getBeginTime().toSec();
    const double span = std::max(1e-9, view.getEndTime().toSec() - begin);
    for (const rosbag::MessageInstance& m : view) {
      const double fraction = (m.getTime().toSec() - begin) / span;
      // One Imu feeds the accelerometer and, when the twist is combined, the gyro.
      if (m.getTopic() == topics_.imu_data) {
        if (!readImu(m, callback, fraction, error)) return false;
      } else if (combiner_ && m.getTopic() == topics_.wheel_odometry) {
        if (!readWheelOdometry(m, callback, fraction, error)) return false;
      } else if (m.getTopic() == topics_.twist) {
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
  const std::unique_ptr<tf2::BufferCore> buffer = staticBuffer(transforms);
  try {
    *target_T_source = ros_conversions::toIsometry(
        buffer->lookupTransform(target_frame, source_frame, ros::Time(0)).transform);
  } catch (const tf2::TransformException& e) {
    if (error)
      *error = "no static transform " + target_frame + " -> " + source_frame + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace ekf_vislam
