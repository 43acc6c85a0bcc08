#include "ekf_vislam/tracker/image_rectifier.h"

#include "testing/raw_camera_image.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace ekf_vislam {
namespace {

using testing::rawImageOf;

// A KITTI-sized raw camera with a strong barrel distortion and a rectifying turn of 0.5 degrees.
RawCameraModel distortedCamera(const std::string& distortion_model = "plumb_bob") {
  RawCameraModel model;
  model.width = 1241;
  model.height = 376;
  model.distortion_model = distortion_model;
  if (distortion_model == "equidistant") {
    model.D = {0.05, -0.02, 0.004, -0.001};
  } else if (distortion_model == "rational_polynomial") {
    model.D = {-0.30, 0.12, 4e-4, -6e-4, -0.02, 0.01, 0.005, 0.001};
  } else {
    model.D = {-0.30, 0.12, 4e-4, -6e-4, -0.02};
  }
  model.K = {718.0, 0.0, 615.0, 0.0, 716.0, 181.0, 0.0, 0.0, 1.0};
  const double a = 0.5 * M_PI / 180.0;
  model.R = {std::cos(a), 0.0, std::sin(a), 0.0, 1.0, 0.0, -std::sin(a), 0.0, std::cos(a)};
  model.P = {700.0, 0.0, 610.0, 0.0, 0.0, 700.0, 186.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  return model;
}

cv::Point2d centroidNear(const cv::Mat& image, const cv::Point2d& around, int radius) {
  double sum = 0.0, su = 0.0, sv = 0.0;
  for (int v = static_cast<int>(around.y) - radius; v <= static_cast<int>(around.y) + radius; ++v) {
    for (int u = static_cast<int>(around.x) - radius; u <= static_cast<int>(around.x) + radius;
         ++u) {
      const double w = image.at<uint8_t>(v, u);
      sum += w;
      su += w * u;
      sv += w * v;
    }
  }
  return {su / sum, sv / sum};
}

TEST(ImageRectifier, RemapsARawImageBackToTheRectifiedScene) {
  for (const std::string model : {"plumb_bob", "rational_polynomial", "equidistant"}) {
    ImageRectifier rectifier;
    std::string why;
    ASSERT_TRUE(rectifier.reset(distortedCamera(model), &why)) << why;
    cv::Mat truth(376, 1241, CV_8UC1);
    cv::randu(truth, 0, 256);
    cv::GaussianBlur(truth, truth, cv::Size(0, 0), 3.0);
    cv::normalize(truth, truth, 0, 255, cv::NORM_MINMAX);
    const cv::Mat raw = rawImageOf(truth, rectifier);
    cv::Mat rectified;
    ASSERT_TRUE(rectifier.rectify(raw, &rectified));
    ASSERT_EQ(rectified.size(), truth.size());
    // Away from the border the raw image does not cover, within a few gray levels (two
    // interpolations); a rectification that ignored R or D would be off by tens.
    const cv::Rect inner(100, 60, 1041, 256);
    cv::Mat difference;
    cv::absdiff(rectified(inner), truth(inner), difference);
    EXPECT_LT(cv::mean(difference)[0], 1.5) << model;
    cv::Mat unrotated;
    cv::absdiff(raw(inner), truth(inner), unrotated);
    EXPECT_GT(cv::mean(unrotated)[0], 10.0) << model;
  }
}

TEST(ImageRectifier, PutsARawPointWhereTheModelProjectsIt) {
  ImageRectifier rectifier;
  std::string why;
  ASSERT_TRUE(rectifier.reset(distortedCamera(), &why)) << why;
  for (const cv::Point2d raw_point : {cv::Point2d(180.3, 70.6), cv::Point2d(620.5, 190.2),
                                      cv::Point2d(1050.7, 300.4), cv::Point2d(300.2, 300.9)}) {
    cv::Mat raw = cv::Mat::zeros(376, 1241, CV_8UC1);
    for (int v = 0; v < raw.rows; ++v) {
      for (int u = 0; u < raw.cols; ++u) {
        const double d2 = std::pow(u - raw_point.x, 2) + std::pow(v - raw_point.y, 2);
        raw.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(250.0 * std::exp(-d2 / (2 * 1.5 * 1.5)));
      }
    }
    cv::Mat rectified;
    ASSERT_TRUE(rectifier.rectify(raw, &rectified));
    const cv::Point2d expected = rectifier.rectifiedPixel(raw_point);
    const cv::Point2d seen = centroidNear(rectified, expected, 7);
    EXPECT_LT(cv::norm(seen - expected), 0.15) << raw_point << " -> " << expected << ", " << seen;
    EXPECT_GT(cv::norm(expected - raw_point), 3.0);  // the model moves it
  }
}

TEST(ImageRectifier, RefusesModelsAndImagesItCannotUse) {
  ImageRectifier rectifier;
  std::string why;
  RawCameraModel model = distortedCamera();
  model.distortion_model = "fov";
  EXPECT_FALSE(rectifier.reset(model, &why));
  EXPECT_NE(why.find("fov"), std::string::npos) << why;
  model = distortedCamera();
  model.D.push_back(0.0);
  EXPECT_FALSE(rectifier.reset(model, &why));
  model = distortedCamera();
  model.R[0] = 2.0;
  EXPECT_FALSE(rectifier.reset(model, &why));
  EXPECT_NE(why.find("rotation"), std::string::npos) << why;
  model = distortedCamera();
  model.K[0] = 0.0;
  EXPECT_FALSE(rectifier.reset(model, &why));
  model = distortedCamera();
  model.P[5] = NAN;
  EXPECT_FALSE(rectifier.reset(model, &why));
  EXPECT_FALSE(rectifier.ready());
  cv::Mat out;
  EXPECT_FALSE(rectifier.rectify(cv::Mat::zeros(376, 1241, CV_8UC1), &out));

  model = distortedCamera();
  model.D.resize(4);  // plumb_bob without k3: taken as 0
  ASSERT_TRUE(rectifier.reset(model, &why)) << why;
  EXPECT_TRUE(rectifier.model() == model);  // as given, so the next camera_info does not remake it
  EXPECT_FALSE(rectifier.rectify(cv::Mat::zeros(370, 1241, CV_8UC1), &out));
  EXPECT_FALSE(rectifier.rectify(cv::Mat::zeros(376, 1241, CV_8UC3), &out));
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(rectifier.rectify(cv::Mat::zeros(376, 1241, CV_8UC1), &out));
}

}  // namespace
}  // namespace ekf_vislam
