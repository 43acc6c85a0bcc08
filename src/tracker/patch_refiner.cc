#include "ekf_vislam/tracker/patch_refiner.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

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

// One row of warped samples: out[c] = sample(image, u0 + c * du, v0 + c * dv), c < count. With
// AVX2, eight at a time by gathers that read two bytes past each sample's right neighbour:
// `gather_safe` says that the row below every sample's lower row lies in the image (so those
// bytes are in the image's memory); else one at a time.
inline void sampleRow(const cv::Mat& image, float u0, float v0, float du, float dv, int count,
                      bool gather_safe, float* out) {
  int c = 0;
#if defined(__AVX2__) && defined(__FMA__)
  if (gather_safe && count >= 8) {
    const __m256 u_start = _mm256_set1_ps(u0), v_start = _mm256_set1_ps(v0);
    const __m256 u_step = _mm256_set1_ps(du), v_step = _mm256_set1_ps(dv);
    const __m256i step = _mm256_set1_epi32(static_cast<int>(image.step[0]));
    const __m256i low_byte = _mm256_set1_epi32(0xFF);
    const int* base0 = reinterpret_cast<const int*>(image.data);
    const int* base1 = reinterpret_cast<const int*>(image.data + image.step[0]);
    for (;; c += 8) {
      if (c + 8 > count) c = count - 8;  // the last eight overlap the ones before
      const __m256 column = _mm256_add_ps(_mm256_set1_ps(static_cast<float>(c)),
                                          _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7));
      const __m256 u = _mm256_fmadd_ps(column, u_step, u_start);
      const __m256 v = _mm256_fmadd_ps(column, v_step, v_start);
      const __m256i x = _mm256_cvttps_epi32(u), y = _mm256_cvttps_epi32(v);
      const __m256 ax = _mm256_sub_ps(u, _mm256_cvtepi32_ps(x));
      const __m256 ay = _mm256_sub_ps(v, _mm256_cvtepi32_ps(y));
      const __m256i offset = _mm256_add_epi32(_mm256_mullo_epi32(y, step), x);
      const __m256i upper = _mm256_i32gather_epi32(base0, offset, 1);
      const __m256i lower = _mm256_i32gather_epi32(base1, offset, 1);
      const __m256 p00 = _mm256_cvtepi32_ps(_mm256_and_si256(upper, low_byte));
      const __m256 p01 =
          _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(upper, 8), low_byte));
      const __m256 p10 = _mm256_cvtepi32_ps(_mm256_and_si256(lower, low_byte));
      const __m256 p11 =
          _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(lower, 8), low_byte));
      const __m256 top = _mm256_fmadd_ps(ax, _mm256_sub_ps(p01, p00), p00);
      const __m256 bottom = _mm256_fmadd_ps(ax, _mm256_sub_ps(p11, p10), p10);
      _mm256_storeu_ps(out + c, _mm256_fmadd_ps(ay, _mm256_sub_ps(bottom, top), top));
      if (c + 8 == count) return;
    }
  }
#else
  (void)gather_safe;
#endif
  for (; c < count; ++c) out[c] = sample(image, u0 + c * du, v0 + c * dv);
}

// Half the width and height of the box that holds every point A * x + t with |x|, |y| <= half.
Eigen::Vector2f warpExtent(const AffineWarp& warp, float half) {
  return half * Eigen::Vector2f(std::abs(warp.A(0, 0)) + std::abs(warp.A(0, 1)),
                                std::abs(warp.A(1, 0)) + std::abs(warp.A(1, 1)));
}

// Whether every point of a box of that extent about t lies where sample() may read.
bool warpInside(const AffineWarp& warp, const Eigen::Vector2f& extent, const cv::Size& size) {
  return warp.t.x() - extent.x() >= 0 && warp.t.y() - extent.y() >= 0 &&
         warp.t.x() + extent.x() < size.width - 1 && warp.t.y() + extent.y() < size.height - 1;
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
  thread_local std::vector<float> grid;
  grid.resize(static_cast<size_t>(wide) * wide);
  for (int r = 0; r < wide; ++r) {
    const uint8_t* row = image.ptr<uint8_t>(pv + r - half - 1) + (pu - half - 1);
    for (int c = 0; c < wide; ++c) grid[static_cast<size_t>(r) * wide + c] = row[c];
  }
  const Eigen::Index n = static_cast<Eigen::Index>(size) * size;
  values_.resize(n);
  steepest_.resize(n, 6);
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) {
      const size_t g = static_cast<size_t>(r + 1) * wide + (c + 1);
      const float gx = 0.5f * (grid[g + 1] - grid[g - 1]);
      const float gy = 0.5f * (grid[g + wide] - grid[g - wide]);
      const float x = c - half + offset_.x(), y = r - half + offset_.y();
      const Eigen::Index i = static_cast<Eigen::Index>(r) * size + c;
      values_(i) = grid[g];
      steepest_.row(i) << gx * x, gy * x, gx * y, gy * y, gx, gy;
    }
  }
  values_.array() -= values_.mean();
  const float sum_squares = values_.squaredNorm();
  norm_ = std::sqrt(sum_squares);
  if (!(norm_ > 0)) return false;
  // The residual is taken after removing the image samples' mean and gain: project both out of
  // the steepest-descent images (Baker and Matthews' "project out"), or the Gauss-Newton step
  // would be too short along every parameter whose steepest-descent image has a mean or
  // correlates with the patch. values_ are zero-mean: the two projections are orthogonal.
  const Eigen::Matrix<float, 1, 6> column_mean = steepest_.colwise().mean();
  const Eigen::Matrix<float, 1, 6> along_patch = (values_.transpose() * steepest_) / sum_squares;
  steepest_.rowwise() -= column_mean;
  steepest_.noalias() -= values_ * along_patch;
  // Columns are contiguous (column-major): each entry a vectorised dot product.
  const Eigen::Matrix<double, 6, 6> hessian =
      steepest_.transpose().lazyProduct(steepest_).cast<double>();
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
  thread_local Eigen::VectorXf warped;
  warped.resize(values_.size());
  AffineWarp w = *warp;
  for (int iteration = 0; iteration <= options.max_iterations; ++iteration) {
    const Eigen::Vector2f extent = warpExtent(w, half + 0.5f);
    if (!warpInside(w, extent, image.size())) {
      result.inside = false;
      return result;
    }
    // Image samples at the current warp, normalised to the reference's gain (zero mean).
    const bool gather_safe = w.t.y() + extent.y() < image.rows - 2;
    for (int r = 0; r < size_; ++r) {
      const float x = -half + offset_.x(), y = r - half + offset_.y();
      sampleRow(image, w.t.x() + x * w.A(0, 0) + y * w.A(0, 1),
                w.t.y() + x * w.A(1, 0) + y * w.A(1, 1), w.A(0, 0), w.A(1, 0), size_, gather_safe,
                warped.data() + static_cast<Eigen::Index>(r) * size_);
    }
    warped.array() -= warped.mean();
    const float image_norm = warped.norm();
    result.zncc = image_norm > 0 ? warped.dot(values_) / (image_norm * norm_) : 0.0;
    if (iteration == options.max_iterations || !(image_norm > 0)) break;
    const float gain = norm_ / image_norm;

    warped = gain * warped - values_;  // the residual
    const Eigen::Matrix<float, 6, 1> b = steepest_.transpose().lazyProduct(warped);
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
