#include "ekf_vislam/ros/gray_image.h"

#include "ekf_vislam/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <future>
#include <string>

namespace ekf_vislam {

namespace enc = sensor_msgs::image_encodings;

const char* const kTrackableEncodings =
    "mono8, 8UC1, bgr8, rgb8, bgra8, rgba8, bayer_rggb8, bayer_bggr8, bayer_gbrg8, bayer_grbg8 or "
    "the same at 16 bits (mono16, 16UC1, bgr16, ..., bayer_grbg16)";

namespace {

// The cv::cvtColor code that takes a colour or Bayer encoding (8 or 16 bits) to gray, or -1 for
// another one. OpenCV names a Bayer pattern by the second row's first two pixels: ROS's RGGB is
// its BG (as cv_bridge and image_proc's debayer convert them).
int toGrayCode(const std::string& encoding) {
  if (encoding == enc::BGR8 || encoding == enc::BGR16) return cv::COLOR_BGR2GRAY;
  if (encoding == enc::RGB8 || encoding == enc::RGB16) return cv::COLOR_RGB2GRAY;
  if (encoding == enc::BGRA8 || encoding == enc::BGRA16) return cv::COLOR_BGRA2GRAY;
  if (encoding == enc::RGBA8 || encoding == enc::RGBA16) return cv::COLOR_RGBA2GRAY;
  if (encoding == enc::BAYER_RGGB8 || encoding == enc::BAYER_RGGB16) {
    return cv::COLOR_BayerBG2GRAY;
  }
  if (encoding == enc::BAYER_BGGR8 || encoding == enc::BAYER_BGGR16) {
    return cv::COLOR_BayerRG2GRAY;
  }
  if (encoding == enc::BAYER_GBRG8 || encoding == enc::BAYER_GBRG16) {
    return cv::COLOR_BayerGR2GRAY;
  }
  if (encoding == enc::BAYER_GRBG8 || encoding == enc::BAYER_GRBG16) {
    return cv::COLOR_BayerGB2GRAY;
  }
  return -1;
}

// A 16-bit image stored in the other byte order than this machine's, as a CV_16UC(channels) copy
// in this machine's order (cv_bridge's own conversion of such an image returns an 8-bit one of
// twice the channels).
cv::Mat byteSwapped16(const sensor_msgs::Image& msg, int channels) {
  cv::Mat swapped(static_cast<int>(msg.height), static_cast<int>(msg.width), CV_16UC(channels));
  const size_t values = static_cast<size_t>(msg.width) * static_cast<size_t>(channels);
  for (int row = 0; row < swapped.rows; ++row) {
    const uint8_t* in = msg.data.data() + static_cast<size_t>(row) * msg.step;
    auto* out = swapped.ptr<uint16_t>(row);
    for (size_t k = 0; k < values; ++k) {
      out[k] = static_cast<uint16_t>((in[2 * k] << 8) | in[2 * k + 1]);
    }
  }
  return swapped;
}

bool isGrayEncoding(const std::string& encoding) {
  return encoding == enc::MONO8 || encoding == enc::TYPE_8UC1 || encoding == enc::MONO16 ||
         encoding == enc::TYPE_16UC1;
}

}  // namespace

bool isTrackableEncoding(const std::string& encoding) {
  return isGrayEncoding(encoding) || toGrayCode(encoding) >= 0;
}

bool toGrayImage(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why) {
  if (!isTrackableEncoding(msg->encoding)) {
    *why = "encoding '" + msg->encoding + "' (expected " + kTrackableEncodings + ")";
    return false;
  }
  const int channels = enc::numChannels(msg->encoding);
  const int value_bytes = enc::bitDepth(msg->encoding) / 8;
  const size_t bytes_per_pixel = static_cast<size_t>(channels) * static_cast<size_t>(value_bytes);
  if (msg->step < msg->width * bytes_per_pixel ||
      static_cast<size_t>(msg->step) * msg->height > msg->data.size()) {
    *why = "image data shorter than its step and height say (" + std::to_string(msg->data.size()) +
           " bytes for step " + std::to_string(msg->step) + " and " + std::to_string(msg->height) +
           " rows)";
    return false;
  }
  try {
    constexpr bool kBigEndianMachine = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;
    const bool swap = value_bytes == 2 && (msg->is_bigendian != 0) != kBigEndianMachine;
    const cv::Mat image =
        swap ? byteSwapped16(*msg, channels) : cv_bridge::toCvShare(msg)->image;  // no copy
    const int code = toGrayCode(msg->encoding);
    if (code < 0) {
      *gray = image;
    } else {
      cv::cvtColor(image, *gray, code);
    }
  } catch (const cv_bridge::Exception& e) {
    *why = std::string("cannot convert the image: ") + e.what();
    return false;
  }
  return true;
}

bool toGrayPair(const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right,
                DeepImageScale* scale, cv::Mat* left_gray, cv::Mat* right_gray, std::string* why) {
  if (!toGrayImage(left, left_gray, why) || !toGrayImage(right, right_gray, why)) return false;
  scale->scalePair(left_gray, right_gray);
  return true;
}

sensor_msgs::ImagePtr decompressedImage(const sensor_msgs::CompressedImage& msg, std::string* why) {
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(msg.data, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    // left empty: said below
  }
  if (decoded.empty()) {
    *why = "compressed image (format '" + msg.format + "') that cannot be decoded";
    return nullptr;
  }
  // What the tracker takes, or a name it refuses (said in its warning).
  std::string encoding = "decoded type " + std::to_string(decoded.type());
  if (decoded.type() == CV_8UC1) encoding = enc::MONO8;
  if (decoded.type() == CV_8UC3) encoding = enc::BGR8;
  if (decoded.type() == CV_8UC4) encoding = enc::BGRA8;
  if (decoded.type() == CV_16UC1) encoding = enc::MONO16;
  if (decoded.type() == CV_16UC3) encoding = enc::BGR16;
  if (decoded.type() == CV_16UC4) encoding = enc::BGRA16;
  cv_bridge::CvImage image(msg.header, encoding, decoded);
  return image.toImageMsg();
}

DecompressedPair decompressedPair(const sensor_msgs::CompressedImage& left,
                                  const sensor_msgs::CompressedImage& right) {
  DecompressedPair pair;
  std::future<sensor_msgs::ImagePtr> right_future =
      std::async(std::launch::async, [&] { return decompressedImage(right, &pair.why_right); });
  pair.left = decompressedImage(left, &pair.why_left);
  pair.right = right_future.get();
  return pair;
}

PairCalibration pairCalibration(const sensor_msgs::CameraInfo& left_info,
                                const sensor_msgs::CameraInfo& right_info,
                                const sensor_msgs::Image& left, StereoCalibration* stereo,
                                std::string* why) {
  StereoCalibration calibration;
  std::string error;
  if (!ros_conversions::calibrationFromCameraInfo(left_info, right_info, &calibration, &error)) {
    *why = "camera_info refused: " + error;
    return PairCalibration::kCameraInfoRefused;
  }
  // The calibration's size is the left camera_info's with its binning and roi applied.
  const int width = calibration.image_width, height = calibration.image_height;
  if ((width != 0 && width != static_cast<int>(left.width)) ||
      (height != 0 && height != static_cast<int>(left.height))) {
    *why = "image size " + std::to_string(left.width) + "x" + std::to_string(left.height) +
           " differs from its camera_info's, " + std::to_string(width) + "x" +
           std::to_string(height) + " (binning and roi applied)";
    return PairCalibration::kSizeMismatch;
  }
  *stereo = calibration;
  return PairCalibration::kOk;
}

}  // namespace ekf_vislam
