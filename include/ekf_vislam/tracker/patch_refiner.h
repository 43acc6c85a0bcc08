// Sub-pixel refinement of a tracked point against a reference patch: inverse-compositional
// Lucas-Kanade (Baker and Matthews) with an affine warp and a gain/bias normalisation of the
// image samples. The tracker keeps each track's first left patch and aligns it to every new left
// image (so a track does not drift with the frame-to-frame KLT), and aligns the current left
// patch to the right image (the stereo match). No ROS.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace ekf_vislam {

/// Maps reference patch coordinates x (px, relative to the patch centre) into an image:
/// A * x + t. t is where the patch centre lies.
struct AffineWarp {
  Eigen::Matrix2f A = Eigen::Matrix2f::Identity();
  Eigen::Vector2f t = Eigen::Vector2f::Zero();
};

enum class WarpModel {
  kAffine,  ///< 6 parameters: any affine map
  kStereo,  ///< 4 parameters: x' = a x + b y + c, y' = y + d (a rectified left-right pair: a
            ///< plane's disparity is affine in u and v, rows stay rows)
};

struct PatchRefinerOptions {
  int max_iterations = 10;
  double epsilon = 0.01;  ///< px: stop when an update moves the patch centre by less
};

/// Why a refinement stopped.
struct RefineResult {
  bool converged = false;  ///< the last update moved the patch centre by less than epsilon
  bool inside = true;      ///< false: the warped patch left the image (*warp unchanged)
  int iterations = 0;
  double zncc = 0;  ///< zero-mean normalised cross-correlation of the reference and the warped
                    ///< image samples at the final warp, -1..1
};

/// A square patch of `size` x `size` pixels (odd) of an 8-bit image around a sub-pixel centre
/// (the pixels about the nearest one),
/// with what inverse-compositional Lucas-Kanade precomputes: its gradients' steepest-descent
/// images and the inverse Hessian of the chosen warp model.
class ReferencePatch {
 public:
  /// Takes the patch of `image` (8-bit single channel) around `center`. False (and invalid) when
  /// it, plus a one-pixel border, does not fit in the image or its Hessian is singular (too
  /// little texture).
  bool create(const cv::Mat& image, const cv::Point2f& center, int size, WarpModel model);
  bool valid() const { return size_ > 0; }
  int size() const { return size_; }
  WarpModel model() const { return model_; }
  const cv::Point2f& center() const { return center_; }

  /// Aligns the patch to `image` (8-bit single channel), starting from *warp, and leaves the
  /// last estimate in *warp (unchanged when the warped patch leaves the image).
  RefineResult align(const cv::Mat& image, const PatchRefinerOptions& options,
                     AffineWarp* warp) const;

 private:
  int size_ = 0;
  WarpModel model_ = WarpModel::kAffine;
  cv::Point2f center_;
  Eigen::Vector2f offset_ = Eigen::Vector2f::Zero();  ///< nearest pixel minus the centre
  Eigen::VectorXf values_;                            ///< zero-mean samples, row after row
  /// Per sample (row), the gradient times the warp Jacobian (6 columns), with the samples'
  /// mean and the patch projected out.
  Eigen::Matrix<float, Eigen::Dynamic, 6> steepest_;
  Eigen::Matrix<float, 6, 6> inverse_hessian_ = Eigen::Matrix<float, 6, 6>::Zero();
  float norm_ = 0;  ///< sqrt of the sum of squared zero-mean samples
};

}  // namespace ekf_vislam
