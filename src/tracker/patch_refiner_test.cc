#include "ekf_vislam/tracker/patch_refiner.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <random>

namespace ekf_vislam {
namespace {

// A smooth texture known everywhere (a sum of Gaussian blobs), so that an image of it under any
// affine map is exact up to the 8-bit quantisation.
class BlobTexture {
 public:
  explicit BlobTexture(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> position(-40, 240), sigma(2.0, 5.0), weight(-80, 80);
    for (int i = 0; i < 900; ++i) {
      blobs_.push_back({position(rng), position(rng), sigma(rng), weight(rng)});
    }
  }
  double at(double x, double y) const {
    double value = 128;
    for (const Blob& b : blobs_) {
      const double dx = x - b.x, dy = y - b.y;
      const double r2 = dx * dx + dy * dy;
      if (r2 < 25 * b.sigma * b.sigma)
        value += b.weight * std::exp(-0.5 * r2 / (b.sigma * b.sigma));
    }
    return value;
  }
  /// The image whose pixel p shows the texture at world_from_image(p), times gain plus bias.
  cv::Mat render(const Eigen::Affine2d& world_from_image, double gain = 1, double bias = 0) const {
    cv::Mat image(200, 200, CV_8UC1);
    for (int v = 0; v < image.rows; ++v) {
      for (int u = 0; u < image.cols; ++u) {
        const Eigen::Vector2d w = world_from_image * Eigen::Vector2d(u, v);
        image.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(gain * at(w.x(), w.y()) + bias);
      }
    }
    return image;
  }

 private:
  struct Blob {
    double x, y, sigma, weight;
  };
  std::vector<Blob> blobs_;
};

// The image of `world` under image_from_world (an affine map about the point (100, 100)).
Eigen::Affine2d mapAbout(const Eigen::Matrix2d& linear, const Eigen::Vector2d& shift) {
  const Eigen::Vector2d c(100, 100);
  Eigen::Affine2d image_from_world = Eigen::Affine2d::Identity();
  image_from_world.linear() = linear;
  image_from_world.translation() = c + shift - linear * c;
  return image_from_world;
}

TEST(PatchRefiner, RecoversAKnownAffineWarpWithGainAndBias) {
  const BlobTexture texture(1);
  const cv::Mat reference_image = texture.render(Eigen::Affine2d::Identity());
  ReferencePatch patch;
  const cv::Point2f center(100.3f, 99.6f);
  ASSERT_TRUE(patch.create(reference_image, center, 15, WarpModel::kAffine));

  // Zoom 1.15, 6 degrees of rotation, 0.08 shear, a 3.4 px shift; 0.8 gain, +25 bias.
  Eigen::Matrix2d linear = 1.15 * Eigen::Rotation2Dd(0.105).toRotationMatrix();
  linear(0, 1) += 0.08;
  const Eigen::Affine2d image_from_world = mapAbout(linear, Eigen::Vector2d(3.4, -2.2));
  const cv::Mat image = texture.render(image_from_world.inverse(), 0.8, 25);
  const Eigen::Vector2d truth = image_from_world * Eigen::Vector2d(center.x, center.y);

  // Start as a KLT would leave it: 0.6 px off, no shape.
  AffineWarp warp;
  warp.t = truth.cast<float>() + Eigen::Vector2f(0.6f, -0.4f);
  PatchRefinerOptions options;
  options.max_iterations = 30;
  options.epsilon = 0.001;
  const RefineResult result = patch.align(image, options, &warp);
  ASSERT_TRUE(result.inside);
  EXPECT_TRUE(result.converged);
  EXPECT_GT(result.zncc, 0.99);
  std::printf("affine: position error %.4f px after %d iterations\n",
              (warp.t.cast<double>() - truth).norm(), result.iterations);
  EXPECT_LT((warp.t.cast<double>() - truth).norm(), 0.05) << warp.t.transpose();
  EXPECT_LT((warp.A.cast<double>() - linear).cwiseAbs().maxCoeff(), 0.02) << warp.A;
}

TEST(PatchRefiner, CarryingTheWarpFollowsAGrowingPatchWithoutDrift) {
  // Twelve frames, each zooming 6 % more about a moving point: the reference of frame 0 aligned
  // to every frame, the warp carried, the start point 0.4 px off each time.
  const BlobTexture texture(2);
  ReferencePatch patch;
  const cv::Point2f center(97.5f, 102.25f);
  ASSERT_TRUE(
      patch.create(texture.render(Eigen::Affine2d::Identity()), center, 15, WarpModel::kAffine));
  AffineWarp warp;
  warp.t = Eigen::Vector2f(center.x, center.y);
  double worst = 0;
  for (int k = 1; k <= 12; ++k) {
    Eigen::Matrix2d linear = std::pow(1.06, k) * Eigen::Matrix2d::Identity();
    linear(0, 1) = 0.02 * k;  // a growing shear, as a surface seen at a grazing angle
    const Eigen::Affine2d image_from_world = mapAbout(linear, Eigen::Vector2d(-1.5 * k, 0.7 * k));
    const cv::Mat image = texture.render(image_from_world.inverse(), 1.0 - 0.02 * k, 2.0 * k);
    const Eigen::Vector2d truth = image_from_world * Eigen::Vector2d(center.x, center.y);
    warp.t = truth.cast<float>() + Eigen::Vector2f(0.4f, 0.3f);
    const RefineResult result = patch.align(image, PatchRefinerOptions(), &warp);
    ASSERT_TRUE(result.inside && result.converged) << "frame " << k;
    worst = std::max(worst, (warp.t.cast<double>() - truth).norm());
  }
  std::printf("carried warp: worst position error over 12 frames %.4f px\n", worst);
  EXPECT_LT(worst, 0.05);
}

TEST(PatchRefiner, StereoModelRecoversTheDisparityOfASlantedPlane) {
  // Right image of a plane whose disparity grows along u and v: x' = 0.93 x - 0.05 y - 11.3.
  const BlobTexture texture(3);
  const cv::Mat left = texture.render(Eigen::Affine2d::Identity());
  Eigen::Matrix2d linear;
  linear << 0.93, -0.05, 0.0, 1.0;
  const Eigen::Affine2d right_from_left = mapAbout(linear, Eigen::Vector2d(-11.3, 0));
  const cv::Mat right = texture.render(right_from_left.inverse());
  const cv::Point2f center(110.0f, 95.0f);
  ReferencePatch patch;
  ASSERT_TRUE(patch.create(left, center, 15, WarpModel::kStereo));
  const Eigen::Vector2d truth = right_from_left * Eigen::Vector2d(center.x, center.y);
  AffineWarp warp;
  warp.t = truth.cast<float>() + Eigen::Vector2f(0.7f, 0.2f);
  const RefineResult result = patch.align(right, PatchRefinerOptions(), &warp);
  ASSERT_TRUE(result.inside);
  EXPECT_TRUE(result.converged);
  std::printf("stereo: position error %.4f px\n", (warp.t.cast<double>() - truth).norm());
  EXPECT_LT((warp.t.cast<double>() - truth).norm(), 0.05) << warp.t.transpose();
  EXPECT_FLOAT_EQ(warp.A(1, 0), 0.f);  // rows stay rows
  EXPECT_FLOAT_EQ(warp.A(1, 1), 1.f);
}

TEST(PatchRefiner, APatchAtTheImageBottomAlignsAsAnywhere) {
  // align() samples eight pixels at a time where the image holds a row below every sample's
  // lower row, one at a time nearer the bottom: the same patch aligned in the full image (the
  // first way) and in a 30-row crop that puts it at the crop's bottom (the second) must agree.
  const BlobTexture texture(6);
  ReferencePatch patch;
  ASSERT_TRUE(patch.create(texture.render(Eigen::Affine2d::Identity()), cv::Point2f(100, 100), 15,
                           WarpModel::kAffine));
  Eigen::Matrix2d linear;
  linear << 1.01, 0.01, -0.01, 1.01;
  const cv::Mat full = texture.render(mapAbout(linear, Eigen::Vector2d(0.4, 0.2)).inverse());
  const int top = 79;  // the truth at row 21.2 of the crop, the patch down to row 28.9
  const cv::Mat crop = full.rowRange(top, top + 30).clone();
  AffineWarp in_full, in_crop;
  in_full.t = Eigen::Vector2f(100.6f, 100.3f);
  in_crop.t = in_full.t - Eigen::Vector2f(0, top);
  const RefineResult full_result = patch.align(full, PatchRefinerOptions(), &in_full);
  const RefineResult crop_result = patch.align(crop, PatchRefinerOptions(), &in_crop);
  ASSERT_TRUE(full_result.inside && crop_result.inside);
  EXPECT_TRUE(full_result.converged);
  EXPECT_EQ(full_result.iterations, crop_result.iterations);
  EXPECT_NEAR(full_result.zncc, crop_result.zncc, 1e-6);
  EXPECT_LT((in_crop.t + Eigen::Vector2f(0, top) - in_full.t).norm(), 1e-4);
  EXPECT_LT((in_crop.A - in_full.A).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_LT((in_full.t - Eigen::Vector2f(100.4f, 100.2f)).norm(), 0.1) << in_full.t.transpose();
}

TEST(PatchRefiner, AnUnrelatedImageCorrelatesPoorlyAndBordersAreRefused) {
  const BlobTexture texture(4), other(5);
  ReferencePatch patch;
  ASSERT_TRUE(patch.create(texture.render(Eigen::Affine2d::Identity()), cv::Point2f(100, 100), 15,
                           WarpModel::kAffine));
  AffineWarp warp;
  warp.t = Eigen::Vector2f(100, 100);
  const RefineResult result =
      patch.align(other.render(Eigen::Affine2d::Identity()), PatchRefinerOptions(), &warp);
  EXPECT_LT(result.zncc, 0.9);

  // No patch where it (plus its gradient border) leaves the image, nor on a flat image.
  const cv::Mat image = texture.render(Eigen::Affine2d::Identity());
  EXPECT_FALSE(patch.create(image, cv::Point2f(7.4f, 100), 15, WarpModel::kAffine));
  EXPECT_FALSE(patch.valid());
  EXPECT_TRUE(patch.create(image, cv::Point2f(7.6f, 100), 15, WarpModel::kAffine));
  EXPECT_FALSE(patch.create(cv::Mat(200, 200, CV_8UC1, cv::Scalar(90)), cv::Point2f(100, 100), 15,
                            WarpModel::kAffine));
  AffineWarp outside;
  outside.t = Eigen::Vector2f(195, 100);
  EXPECT_FALSE(patch.align(image, PatchRefinerOptions(), &outside).inside);
  EXPECT_EQ(outside.t, Eigen::Vector2f(195, 100));
}

}  // namespace
}  // namespace ekf_vislam
