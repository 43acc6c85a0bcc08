#include "ekf_vislam/tracker/pyramidal_klt.h"

#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace ekf_vislam {

namespace {

// The widest window the fast path takes: one row is sixteen 16-bit lanes, and the lane after
// the window's last pixel holds its right neighbour.
constexpr int kMaxWindow = 15;
// The fast path reads sixteen bytes (image) or pixels (derivatives) from a window row's first
// column: that many columns of border right of the image, the window's height below it.
constexpr int kRightBorder = 15;
// OpenCV's scale of the window sums (its FLT_SCALE).
constexpr float kSumScale = 1.f / (1 << 20);

struct Level {
  const cv::Mat* prev;   // 8-bit image
  const cv::Mat* deriv;  // its Scharr derivatives, 16-bit (dx, dy)
  const cv::Mat* next;   // 8-bit image
};

#if defined(__AVX2__)

// How many levels above the full image a pyramid from cv::buildOpticalFlowPyramid with
// derivatives holds (-1: not such a pyramid).
int derivativePyramidLevels(const std::vector<cv::Mat>& pyramid) {
  if (pyramid.size() < 2 || pyramid.size() % 2 != 0) return -1;
  for (size_t i = 0; i < pyramid.size(); i += 2) {
    if (pyramid[i].type() != CV_8UC1 || pyramid[i + 1].type() != CV_16SC2) return -1;
  }
  return static_cast<int>(pyramid.size() / 2) - 1;
}

bool bordersHold(const cv::Mat& image, const cv::Size& window) {
  cv::Size whole;
  cv::Point offset;
  image.locateROI(whole, offset);
  return offset.x >= window.width && offset.y >= window.height &&
         whole.width - offset.x - image.cols >= std::max(kRightBorder, window.width) &&
         whole.height - offset.y - image.rows >= window.height;
}

// The fixed-point bilinear weights of OpenCV's KLT (14 bits) for the fractions a, b.
struct Weights {
  int w00, w01, w10, w11;
  Weights(float a, float b) {
    constexpr float kOne = 1 << 14;
    w00 = cvRound((1.f - a) * (1.f - b) * kOne);
    w01 = cvRound(a * (1.f - b) * kOne);
    w10 = cvRound((1.f - a) * b * kOne);
    w11 = (1 << 14) - w00 - w01 - w10;
  }
  __m256i top() const { return _mm256_set1_epi32((w01 << 16) | (w00 & 0xFFFF)); }
  __m256i bottom() const { return _mm256_set1_epi32((w11 << 16) | (w10 & 0xFFFF)); }
};

// Sixteen 8-bit pixels from `row` and their right neighbours (the last lane's neighbour is 0).
inline void loadBytes(const uchar* row, __m256i* pixels, __m256i* right) {
  const __m128i bytes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row));
  *pixels = _mm256_cvtepu8_epi16(bytes);
  *right = _mm256_cvtepu8_epi16(_mm_srli_si128(bytes, 1));
}

// Bilinear interpolation in 16-bit lanes: p0 and p1 hold values and their right neighbours in a
// row, q0 and q1 in the row below; the weighted sum descaled by kShift bits (OpenCV's
// CV_DESCALE), in the lanes' order.
template <int kShift>
inline __m256i bilinear(__m256i p0, __m256i p1, __m256i q0, __m256i q1, const Weights& w) {
  const __m256i round = _mm256_set1_epi32(1 << (kShift - 1));
  const __m256i lo = _mm256_add_epi32(
      _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpacklo_epi16(p0, p1), w.top()),
                       _mm256_madd_epi16(_mm256_unpacklo_epi16(q0, q1), w.bottom())),
      round);
  const __m256i hi = _mm256_add_epi32(
      _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpackhi_epi16(p0, p1), w.top()),
                       _mm256_madd_epi16(_mm256_unpackhi_epi16(q0, q1), w.bottom())),
      round);
  return _mm256_packs_epi32(_mm256_srai_epi32(lo, kShift), _mm256_srai_epi32(hi, kShift));
}

// Bilinear value of sixteen 8-bit pixels, in OpenCV's scale (x 32), as 16-bit lanes.
inline __m256i interpolateBytes(const uchar* row, size_t step, const Weights& w) {
  __m256i p0, p1, q0, q1;
  loadBytes(row, &p0, &p1);
  loadBytes(row + step, &q0, &q1);
  return bilinear<9>(p0, p1, q0, q1, w);
}

// Eight (dx, dy) pixels as 32-bit lanes, and their right neighbours: `next` holds the eight
// after them (its first is the last one's neighbour).
inline __m256i rightNeighbours(__m256i pixels, __m256i next) {
  const __m256i shift = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0);
  return _mm256_blend_epi32(_mm256_permutevar8x32_epi32(pixels, shift),
                            _mm256_permutevar8x32_epi32(next, _mm256_setzero_si256()), 0x80);
}

// The sum of eight 32-bit lanes, in 64 bits: a lane holds at most 30 products of 16-bit values
// below 2^12 and 2^13 (1.0e9), eight of them may pass 2^31.
inline int64_t sum64(__m256i v) {
  const __m256i wide = _mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(v)),
                                        _mm256_cvtepi32_epi64(_mm256_extracti128_si256(v, 1)));
  const __m128i s = _mm_add_epi64(_mm256_castsi256_si128(wide), _mm256_extracti128_si256(wide, 1));
  return _mm_cvtsi128_si64(s) + _mm_extract_epi64(s, 1);
}

// The previous image's window about a point at one level: its values (x 32) and derivatives,
// each row sixteen lanes (derivatives of lanes past the window zero), and their sums.
struct Window {
  __m256i values[kMaxWindow];
  __m256i derivs_lo[kMaxWindow], derivs_hi[kMaxWindow];  // pixels 0-7, 8-15, (dx, dy)
  float a11 = 0, a12 = 0, a22 = 0;
};

void takeWindow(const cv::Mat& image, const cv::Mat& deriv, const cv::Point& corner,
                const Weights& w, const cv::Size& size, Window* window) {
  // Lanes of pixels inside the window (32-bit (dx, dy) lanes of pixels 0-7 and 8-15).
  const __m256i index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i keep_lo = _mm256_cmpgt_epi32(_mm256_set1_epi32(size.width), index);
  const __m256i keep_hi = _mm256_cmpgt_epi32(_mm256_set1_epi32(size.width - 8), index);
  const __m256i low_half = _mm256_set1_epi32(0xFFFF);
  __m256i a11 = _mm256_setzero_si256(), a12 = a11, a22 = a11;
  const size_t dstep = deriv.step[0];
  for (int y = 0; y < size.height; ++y) {
    window->values[y] =
        interpolateBytes(image.ptr<uchar>(corner.y + y) + corner.x, image.step[0], w);
    const auto* d0 = reinterpret_cast<const uchar*>(deriv.ptr<short>(corner.y + y) + 2 * corner.x);
    const __m256i p_lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d0));
    const __m256i p_hi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d0 + 32));
    const __m256i q_lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d0 + dstep));
    const __m256i q_hi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d0 + dstep + 32));
    const __m256i lo = _mm256_and_si256(
        bilinear<14>(p_lo, rightNeighbours(p_lo, p_hi), q_lo, rightNeighbours(q_lo, q_hi), w),
        keep_lo);
    const __m256i hi = _mm256_and_si256(
        bilinear<14>(p_hi, rightNeighbours(p_hi, p_hi), q_hi, rightNeighbours(q_hi, q_hi), w),
        keep_hi);
    window->derivs_lo[y] = lo;
    window->derivs_hi[y] = hi;
    // dx * dx, dy * dy and dx * dy of every pixel, by pairs of 16-bit products.
    const __m256i dx_lo = _mm256_and_si256(lo, low_half), dx_hi = _mm256_and_si256(hi, low_half);
    const __m256i dy_lo = _mm256_srli_epi32(lo, 16), dy_hi = _mm256_srli_epi32(hi, 16);
    a11 = _mm256_add_epi32(
        a11, _mm256_add_epi32(_mm256_madd_epi16(lo, dx_lo), _mm256_madd_epi16(hi, dx_hi)));
    a22 = _mm256_add_epi32(a22,
                           _mm256_add_epi32(_mm256_madd_epi16(lo, _mm256_slli_epi32(dy_lo, 16)),
                                            _mm256_madd_epi16(hi, _mm256_slli_epi32(dy_hi, 16))));
    a12 = _mm256_add_epi32(a12,
                           _mm256_add_epi32(_mm256_madd_epi16(lo, _mm256_slli_epi32(dx_lo, 16)),
                                            _mm256_madd_epi16(hi, _mm256_slli_epi32(dx_hi, 16))));
  }
  window->a11 = static_cast<float>(sum64(a11)) * kSumScale;
  window->a12 = static_cast<float>(sum64(a12)) * kSumScale;
  window->a22 = static_cast<float>(sum64(a22)) * kSumScale;
}

// The mismatch vector b = sum of (J - I) * (dx, dy) over the window, at the next image's corner.
void mismatch(const cv::Mat& next, const cv::Point& corner, const Weights& w, int height,
              const Window& window, float* b1, float* b2) {
  __m256i sum1 = _mm256_setzero_si256(), sum2 = sum1;
  for (int y = 0; y < height; ++y) {
    const __m256i j = interpolateBytes(next.ptr<uchar>(corner.y + y) + corner.x, next.step[0], w);
    // diff in the lanes' order of the derivatives: pixels 0-3 and 4-7 (lo), 8-11 and 12-15 (hi).
    const __m256i diff =
        _mm256_permute4x64_epi64(_mm256_sub_epi16(j, window.values[y]), _MM_SHUFFLE(3, 1, 2, 0));
    const __m256i even_lo = _mm256_unpacklo_epi16(diff, _mm256_setzero_si256());
    const __m256i even_hi = _mm256_unpackhi_epi16(diff, _mm256_setzero_si256());
    sum1 =
        _mm256_add_epi32(sum1, _mm256_add_epi32(_mm256_madd_epi16(window.derivs_lo[y], even_lo),
                                                _mm256_madd_epi16(window.derivs_hi[y], even_hi)));
    sum2 = _mm256_add_epi32(
        sum2,
        _mm256_add_epi32(_mm256_madd_epi16(window.derivs_lo[y], _mm256_slli_epi32(even_lo, 16)),
                         _mm256_madd_epi16(window.derivs_hi[y], _mm256_slli_epi32(even_hi, 16))));
  }
  *b1 = static_cast<float>(sum64(sum1)) * kSumScale;
  *b2 = static_cast<float>(sum64(sum2)) * kSumScale;
}

// One point at one level, as OpenCV's LKTrackerInvoker: false where the point is lost there.
// *next_point is the level's estimate (in the level's pixels).
bool trackAtLevel(const Level& level, const cv::Point2f& prev_point, cv::Point2f* next_point,
                  const cv::Size& size, const cv::TermCriteria& criteria, Window* window) {
  const cv::Point2f half((size.width - 1) * 0.5f, (size.height - 1) * 0.5f);
  const cv::Point2f prev = prev_point - half;
  const cv::Point prev_corner(cvFloor(prev.x), cvFloor(prev.y));
  const cv::Mat& deriv = *level.deriv;
  if (prev_corner.x < -size.width || prev_corner.x >= deriv.cols || prev_corner.y < -size.height ||
      prev_corner.y >= deriv.rows) {
    return false;
  }
  takeWindow(*level.prev, deriv, prev_corner,
             Weights(prev.x - prev_corner.x, prev.y - prev_corner.y), size, window);
  const float a11 = window->a11, a12 = window->a12, a22 = window->a22;
  float d = a11 * a22 - a12 * a12;
  const float min_eig = (a22 + a11 - std::sqrt((a11 - a22) * (a11 - a22) + 4.f * a12 * a12)) /
                        (2 * size.width * size.height);
  if (min_eig < 1e-4f || d < FLT_EPSILON) return false;
  d = 1.f / d;

  const cv::Mat& next = *level.next;
  cv::Point2f point = *next_point - half;
  cv::Point2f prev_delta;
  for (int j = 0; j < criteria.maxCount; ++j) {
    const cv::Point corner(cvFloor(point.x), cvFloor(point.y));
    if (corner.x < -size.width || corner.x >= next.cols || corner.y < -size.height ||
        corner.y >= next.rows) {
      return false;
    }
    float b1, b2;
    mismatch(next, corner, Weights(point.x - corner.x, point.y - corner.y), size.height, *window,
             &b1, &b2);
    const cv::Point2f delta((a12 * b2 - a22 * b1) * d, (a12 * b1 - a11 * b2) * d);
    point += delta;
    *next_point = point + half;
    if (delta.ddot(delta) <= criteria.epsilon) break;
    if (j > 0 && std::abs(delta.x + prev_delta.x) < 0.01 &&
        std::abs(delta.y + prev_delta.y) < 0.01) {
      *next_point -= delta * 0.5f;
      break;
    }
    prev_delta = delta;
  }
  return true;
}

#endif  // __AVX2__

// The levels above the full image the fast path tracks through for these pyramids and settings,
// or -1 where it does not apply (OpenCV's function runs).
int fastPathLevels(const std::vector<cv::Mat>& prev_pyramid,
                   const std::vector<cv::Mat>& next_pyramid, const KltSettings& klt) {
#if defined(__AVX2__)
  const int prev_levels = derivativePyramidLevels(prev_pyramid);
  const int next_levels = derivativePyramidLevels(next_pyramid);
  if (klt.window.width > kMaxWindow || klt.window.height > kMaxWindow || klt.window.width <= 2 ||
      klt.window.height <= 2 || prev_levels < 0 || next_levels < 0) {
    return -1;
  }
  const int levels = std::min({klt.levels, prev_levels, next_levels});
  for (int l = 0; l <= levels; ++l) {
    const cv::Mat& prev = prev_pyramid[2 * l];
    if (prev.size() != next_pyramid[2 * l].size() || !bordersHold(prev, klt.window) ||
        !bordersHold(prev_pyramid[2 * l + 1], klt.window) ||
        !bordersHold(next_pyramid[2 * l], klt.window)) {
      return -1;
    }
  }
  return levels;
#else
  (void)prev_pyramid;
  (void)next_pyramid;
  (void)klt;
  return -1;
#endif
}

}  // namespace

bool pyramidalKltFastPath(const std::vector<cv::Mat>& prev_pyramid,
                          const std::vector<cv::Mat>& next_pyramid, const KltSettings& klt) {
  return fastPathLevels(prev_pyramid, next_pyramid, klt) >= 0;
}

void trackPyramidalKlt(const std::vector<cv::Mat>& prev_pyramid,
                       const std::vector<cv::Mat>& next_pyramid,
                       const std::vector<cv::Point2f>& prev, std::vector<cv::Point2f>* next,
                       std::vector<uint8_t>* status, const KltSettings& klt) {
  const int max_level = fastPathLevels(prev_pyramid, next_pyramid, klt);
  if (max_level < 0) {
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(prev_pyramid, next_pyramid, prev, *next, *status, error, klt.window,
                             klt.levels, klt.criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    return;
  }
#if defined(__AVX2__)
  // OpenCV's reading of the criteria.
  cv::TermCriteria criteria = klt.criteria;
  criteria.maxCount = (criteria.type & cv::TermCriteria::COUNT) == 0
                          ? 30
                          : std::min(std::max(criteria.maxCount, 0), 100);
  criteria.epsilon = (criteria.type & cv::TermCriteria::EPS) == 0
                         ? 0.01
                         : std::min(std::max(criteria.epsilon, 0.), 10.);
  criteria.epsilon *= criteria.epsilon;
  std::vector<Level> levels(max_level + 1);
  for (int l = 0; l <= max_level; ++l) {
    levels[l] = {&prev_pyramid[2 * l], &prev_pyramid[2 * l + 1], &next_pyramid[2 * l]};
  }
  status->assign(prev.size(), 1);
  next->resize(prev.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(prev.size())), [&](const cv::Range& range) {
    Window window;
    for (int i = range.start; i < range.end; ++i) {
      cv::Point2f point = (*next)[i] * static_cast<float>(1. / (1 << max_level));
      for (int l = max_level; l >= 0; --l) {
        if (l < max_level) point *= 2.f;
        const cv::Point2f prev_point = prev[i] * static_cast<float>(1. / (1 << l));
        // A point lost above the full image goes on from where it was (OpenCV's rule).
        if (!trackAtLevel(levels[l], prev_point, &point, klt.window, criteria, &window) && l == 0) {
          (*status)[i] = 0;
        }
      }
      (*next)[i] = point;
    }
  });
#endif
}

}  // namespace ekf_vislam
