#include "ekf_vislam/tracker/patch_refiner.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

namespace {

// Bilinear sample of an 8-bit image; (u, v) must satisfy 0 <= u < cols - 1, 0 <= v < rows - 1.
inline float sample(const cv::Mat& image, float u, float v) {
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const float ax = u - x, ay = v - y;
  const uint8_t* row0 = image.ptr<uint8_t>(y) + x;
  const uint8_t* row1 = image.ptr<uint8_t>(y + 1) + x;
  const float top = row0[0] + ax * (row0[1] - row0[0]);
  const float bottom = row1[0] + ax * (row1[1] - row1[0]);
  return top + ay * (bottom - top);
}

// Whether every point A * x + t with |x|, |y| <= half lies where sample() may read.
bool warpInside(const AffineWarp& warp, float half, const cv::Size& size) {
  const float ex = half * (std::abs(warp.A(0, 0)) + std::abs(warp.A(0, 1)));
  const float ey = half * (std::abs(warp.A(1, 0)) + std::abs(warp.A(1, 1)));
  return warp.t.x() - ex >= 0 && warp.t.y() - ey >= 0 && warp.t.x() + ex < size.width - 1 &&
         warp.t.y() + ey < size.height - 1;
}

// The parameters of each model, as indices into (a11-1, a21, a12, a22-1, tx, ty).
constexpr int kAffineParameters[] = {0, 1, 2, 3, 4, 5};
constexpr int kStereoParameters[] = {0, 2, 4, 5};

template <int N>
bool invertHessian(const Eigen::Matrix<double, 6, 6>& full, const int (&index)[N],
                   Eigen::Matrix<float, 6, 6>* inverse) {
  Eigen::Matrix<double, N, N> h;
  for (int r = 0; r < N; ++r) {
    for (int c = 0; c < N; ++c) h(r, c) = full(index[r], index[c]);
  }
  // Scale-free conditioning test (the parameters have different units): the pivots of the
  // unit-diagonal matrix.
  if (h.diagonal().minCoeff() <= 1e-9) return false;
  const Eigen::Matrix<double, N, 1> d = h.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::LDLT<Eigen::Matrix<double, N, N>> ldlt(d.asDiagonal() * h * d.asDiagonal());
  if (ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() < 1e-4) return false;
  const Eigen::Matrix<double, N, N> inv = h.inverse();
  inverse->setZero();
  for (int r = 0; r < N; ++r) {
    for (int c = 0; c < N; ++c) (*inverse)(index[r], index[c]) = static_cast<float>(inv(r, c));
  }
  return true;
}

}  // namespace

bool ReferencePatch::create(const cv::Mat& image, const cv::Point2f& center, int size,
                            WarpModel model) {
  size_ = 0;
  if (image.empty() || image.type() != CV_8UC1 || size < 3 || size % 2 == 0) return false;
  // The samples sit on the image's pixel grid (no interpolation, which would blur the reference
  // by an amount that depends on the centre's fraction); their coordinates relative to the
  // sub-pixel centre carry the fraction instead.
  const int half = size / 2;
  const int pu = static_cast<int>(std::lround(center.x));
  const int pv = static_cast<int>(std::lround(center.y));
  if (pu - half - 1 < 0 || pv - half - 1 < 0 || pu + half + 1 > image.cols - 1 ||
      pv + half + 1 > image.rows - 1) {
    return false;
  }
  offset_ = Eigen::Vector2f(pu - center.x, pv - center.y);

  // Samples with a one-pixel border, for central-difference gradients.
  const int wide = size + 2;
  std::vector<float> grid(static_cast<size_t>(wide) * wide);
  for (int r = 0; r < wide; ++r) {
    const uint8_t* row = image.ptr<uint8_t>(pv + r - half - 1) + (pu - half - 1);
    for (int c = 0; c < wide; ++c) grid[static_cast<size_t>(r) * wide + c] = row[c];
  }
  const size_t n = static_cast<size_t>(size) * size;
  values_.resize(n);
  steepest_.resize(6 * n);
  double mean = 0;
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) {
      const size_t g = static_cast<size_t>(r + 1) * wide + (c + 1);
      const float gx = 0.5f * (grid[g + 1] - grid[g - 1]);
      const float gy = 0.5f * (grid[g + wide] - grid[g - wide]);
      const float x = c - half + offset_.x(), y = r - half + offset_.y();
      const size_t i = static_cast<size_t>(r) * size + c;
      values_[i] = grid[g];
      mean += grid[g];
      float* s = &steepest_[6 * i];
      s[0] = gx * x;
      s[1] = gy * x;
      s[2] = gx * y;
      s[3] = gy * y;
      s[4] = gx;
      s[5] = gy;
    }
  }
  mean /= static_cast<double>(n);
  double sum_squares = 0;
  for (float& v : values_) {
    v -= static_cast<float>(mean);
    sum_squares += static_cast<double>(v) * v;
  }
  norm_ = static_cast<float>(std::sqrt(sum_squares));
  if (norm_ <= 0) return false;
  // The residual is taken after removing the image samples' mean and gain: project both out of
  // the steepest-descent images (Baker and Matthews' "project out"), or the Gauss-Newton step
  // would be too short along every parameter whose steepest-descent image has a mean or
  // correlates with the patch.
  Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, 6, Eigen::RowMajor>> steepest(
      steepest_.data(), static_cast<Eigen::Index>(n), 6);
  const Eigen::Map<const Eigen::VectorXf> values(values_.data(), static_cast<Eigen::Index>(n));
  const Eigen::Matrix<float, 1, 6> column_mean = steepest.colwise().mean();
  // values_ are zero-mean: the two projections are orthogonal.
  const Eigen::Matrix<float, 1, 6> along_patch =
      (values.transpose() * steepest) / static_cast<float>(sum_squares);
  steepest -=
      Eigen::VectorXf::Ones(static_cast<Eigen::Index>(n)) * column_mean + values * along_patch;
  const Eigen::Matrix<double, 6, 6> hessian = (steepest.transpose() * steepest).cast<double>();
  const bool invertible = model == WarpModel::kAffine
                              ? invertHessian(hessian, kAffineParameters, &inverse_hessian_)
                              : invertHessian(hessian, kStereoParameters, &inverse_hessian_);
  if (!invertible) return false;
  size_ = size;
  model_ = model;
  center_ = center;
  return true;
}

RefineResult ReferencePatch::align(const cv::Mat& image, const PatchRefinerOptions& options,
                                   AffineWarp* warp) const {
  RefineResult result;
  if (!valid()) {
    result.inside = false;
    return result;
  }
  const int half = size_ / 2;
  const size_t n = values_.size();
  std::vector<float> warped(n);
  AffineWarp w = *warp;
  for (int iteration = 0; iteration <= options.max_iterations; ++iteration) {
    if (!warpInside(w, half + 0.5f, image.size())) {
      result.inside = false;
      return result;
    }
    // Image samples at the current warp, normalised to the reference's gain (zero mean).
    double mean = 0;
    for (int r = 0; r < size_; ++r) {
      const float x = -half + offset_.x(), y = r - half + offset_.y();
      float u = w.t.x() + x * w.A(0, 0) + y * w.A(0, 1);
      float v = w.t.y() + x * w.A(1, 0) + y * w.A(1, 1);
      float* out = &warped[static_cast<size_t>(r) * size_];
      for (int c = 0; c < size_; ++c) {
        out[c] = sample(image, u, v);
        mean += out[c];
        u += w.A(0, 0);
        v += w.A(1, 0);
      }
    }
    mean /= static_cast<double>(n);
    double sum_squares = 0, cross = 0;
    for (size_t i = 0; i < n; ++i) {
      warped[i] -= static_cast<float>(mean);
      sum_squares += static_cast<double>(warped[i]) * warped[i];
      cross += static_cast<double>(warped[i]) * values_[i];
    }
    const double image_norm = std::sqrt(sum_squares);
    result.zncc = image_norm > 0 ? cross / (image_norm * norm_) : 0.0;
    if (iteration == options.max_iterations || image_norm <= 0) break;
    const float gain = static_cast<float>(norm_ / image_norm);

    for (size_t i = 0; i < n; ++i) warped[i] = gain * warped[i] - values_[i];  // the residual
    const Eigen::Matrix<float, 6, 1> b =
        Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 6, Eigen::RowMajor>>(
            steepest_.data(), static_cast<Eigen::Index>(n), 6)
            .transpose() *
        Eigen::Map<const Eigen::VectorXf>(warped.data(), static_cast<Eigen::Index>(n));
    const Eigen::Matrix<float, 6, 1> dp = inverse_hessian_ * b;
    // Inverse composition: W(x; p) <- W(x; p) o W(x; dp)^-1.
    Eigen::Matrix2f dA;
    dA << 1 + dp(0), dp(2), dp(1), 1 + dp(3);
    const Eigen::Matrix2f dA_inv = dA.inverse();
    const Eigen::Vector2f dt(dp(4), dp(5));
    const Eigen::Vector2f move = -w.A * dA_inv * dt;  // of the patch centre
    w.t += move;
    w.A = w.A * dA_inv;
    ++result.iterations;
    const float step = move.norm();
    if (!std::isfinite(step)) {
      result.inside = false;
      return result;
    }
    if (step < options.epsilon) {
      // The correlation was measured before this sub-epsilon update: it stands for the result.
      result.converged = true;
      break;
    }
  }
  *warp = w;
  return result;
}

}  // namespace ekf_vislam
