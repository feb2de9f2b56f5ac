// The LBD line descriptor (Zhang and Koch), bit-compatible with OpenCV's BinaryDescriptor.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "line_features_internal.h"
#include "pl_slam/features/line_features.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace line_internal {
namespace {

// LBD layout of OpenCV's BinaryDescriptor defaults; changing them breaks bit-compatibility.
constexpr int kNumBands = 9;
constexpr int kBandWidth = 7;
constexpr int kLsrHeight = kNumBands * kBandWidth;
constexpr int kRowsPadded = 64;  // kLsrHeight rounded up to whole SIMD blocks

// Pairs of bands whose float descriptors are compared bit by bit into one byte (OpenCV order).
constexpr int kBandPairs[32][2] = {{0, 1}, {0, 2}, {0, 3}, {0, 4}, {0, 5}, {0, 6}, {1, 2}, {1, 3},
                                   {1, 4}, {1, 5}, {1, 6}, {2, 3}, {2, 4}, {2, 5}, {2, 6}, {2, 7},
                                   {2, 8}, {3, 4}, {3, 5}, {3, 6}, {3, 7}, {3, 8}, {4, 5}, {4, 6},
                                   {4, 7}, {4, 8}, {5, 6}, {5, 7}, {5, 8}, {6, 7}, {6, 8}, {7, 8}};

// Gaussian weights of the LBD support region, as OpenCV computes them (integer divisions
// included, they are part of the descriptor's definition).
struct LbdWeights {
  std::array<float, kLsrHeight> global{};     // across the whole region (F_g)
  std::array<float, 3 * kBandWidth> local{};  // across a band and its neighbours (F_l)
  LbdWeights() {
    double u = (kBandWidth * 3 - 1) / 2;
    double sigma = (kBandWidth * 2 + 1) / 2;
    double inv = -1.0 / (2.0 * sigma * sigma);
    for (int i = 0; i < 3 * kBandWidth; ++i)
      local[i] = static_cast<float>(std::exp((i - u) * (i - u) * inv));
    u = (kNumBands * kBandWidth - 1) / 2;
    sigma = u;
    inv = -1.0 / (2.0 * sigma * sigma);
    for (int i = 0; i < kLsrHeight; ++i)
      global[i] = static_cast<float>(std::exp((i - u) * (i - u) * inv));
  }
};

const LbdWeights& Weights() {
  static const LbdWeights weights;  // thread-safe initialisation (C++11 magic static)
  return weights;
}

// Float LBD of one line (72 values), then the 256-bit binary descriptor. Mirrors
// BinaryDescriptor::computeLBD operation by operation so that the bits agree with OpenCV.
void LbdOfLine(const cv::Mat& dx_img, const cv::Mat& dy_img, const LineFeature& line,
               uint8_t* out) {
  const LbdWeights& w = Weights();
  const int max_x = dx_img.cols - 1;
  const int max_y = dx_img.rows - 1;
  const int16_t* pdx = dx_img.ptr<int16_t>();
  const int16_t* pdy = dy_img.ptr<int16_t>();
  const size_t step = dx_img.step1();

  // KeyLine stores floats; round through them like OpenCV does.
  const float sx = static_cast<float>(line.s.x()), sy = static_cast<float>(line.s.y());
  const float ex = static_cast<float>(line.e.x()), ey = static_cast<float>(line.e.y());
  const float direction = static_cast<float>(line.angle);
  // The support region is as long as the segment's 8-connected pixel count
  // (KeyLine::numOfPixels, which OpenCV's LSD front end takes from cv::LineIterator).
  const int length_lsr =
      std::max(std::abs(cvRound(ex) - cvRound(sx)), std::abs(cvRound(ey) - cvRound(sy))) + 1;
  const int16_t half_width = static_cast<int16_t>((length_lsr - 1) / 2);
  const int16_t half_height = static_cast<int16_t>((kLsrHeight - 1) / 2);
  const float mid_x = static_cast<float>(0.5 * (sx + ex));
  const float mid_y = static_cast<float>(0.5 * (sy + ey));
  const float dl0 = static_cast<float>(std::cos(static_cast<double>(direction)));
  const float dl1 = static_cast<float>(std::sin(static_cast<double>(direction)));
  const float do0 = -dl1, do1 = dl0;

  float pgdl_band[kNumBands] = {}, ngdl_band[kNumBands] = {}, pgdl2_band[kNumBands] = {},
        ngdl2_band[kNumBands] = {}, pgdo_band[kNumBands] = {}, ngdo_band[kNumBands] = {},
        pgdo2_band[kNumBands] = {}, ngdo2_band[kNumBands] = {};

  // Start of every row of the support region, accumulated row by row like OpenCV does so
  // that each sample lands on the same pixel; one padding row makes four blocks of four.
  alignas(16) float row_x[kRowsPadded], row_y[kRowsPadded];
  float row_x0 = -dl0 * half_width + dl1 * half_height + mid_x;
  float row_y0 = -dl1 * half_width - dl0 * half_height + mid_y;
  for (int h = 0; h < kRowsPadded; ++h) {
    row_x[h] = row_x0;
    row_y[h] = row_y0;
    row_x0 -= dl1;
    row_y0 += dl0;
  }
  // Sums of the positive and negative gradient parts along dL and dO, per row. Four rows
  // run in SIMD lanes: each lane does exactly the scalar operations of its row.
  alignas(16) float row_pgdl[kRowsPadded], row_ngdl[kRowsPadded], row_pgdo[kRowsPadded],
      row_ngdo[kRowsPadded];
  const cv::v_float32x4 v_zero = cv::v_setzero_f32(), v_half = cv::v_setall_f32(0.5f);
  // Clamping x + 0.5 to [0, max + 0.5] before truncation equals clamping round(x) to [0, max].
  const cv::v_float32x4 v_max_x = cv::v_setall_f32(max_x + 0.5f),
                        v_max_y = cv::v_setall_f32(max_y + 0.5f);
  const cv::v_float32x4 v_dl0 = cv::v_setall_f32(dl0), v_dl1 = cv::v_setall_f32(dl1);
  const cv::v_float32x4 v_do0 = cv::v_setall_f32(do0), v_do1 = cv::v_setall_f32(do1);
  const cv::v_int32x4 v_step = cv::v_setall_s32(static_cast<int>(step));
  alignas(16) int idx[4];
  for (int h0 = 0; h0 < kRowsPadded; h0 += 4) {
    cv::v_float32x4 cx = cv::v_load_aligned(row_x + h0), cy = cv::v_load_aligned(row_y + h0);
    cv::v_float32x4 pgdl = v_zero, ngdl = v_zero, pgdo = v_zero, ngdo = v_zero;
    for (int k = 0; k < length_lsr; ++k) {
      const cv::v_int32x4 xi = cv::v_trunc(cv::v_min(cv::v_max(cx + v_half, v_zero), v_max_x));
      const cv::v_int32x4 yi = cv::v_trunc(cv::v_min(cv::v_max(cy + v_half, v_zero), v_max_y));
      cv::v_store_aligned(idx, yi * v_step + xi);
      // Gathers: the samples of a rotated grid are scattered (interleaving dx and dy into
      // one word per pixel was measured slower).
      const cv::v_float32x4 gx =
          cv::v_cvt_f32(cv::v_int32x4(pdx[idx[0]], pdx[idx[1]], pdx[idx[2]], pdx[idx[3]]));
      const cv::v_float32x4 gy =
          cv::v_cvt_f32(cv::v_int32x4(pdy[idx[0]], pdy[idx[1]], pdy[idx[2]], pdy[idx[3]]));
      const cv::v_float32x4 gdl = gx * v_dl0 + gy * v_dl1;
      const cv::v_float32x4 gdo = gx * v_do0 + gy * v_do1;
      // Positive and negative parts; the other one gets an exact zero added.
      pgdl += cv::v_max(gdl, v_zero);
      ngdl += cv::v_max(v_zero - gdl, v_zero);
      pgdo += cv::v_max(gdo, v_zero);
      ngdo += cv::v_max(v_zero - gdo, v_zero);
      cx += v_dl0;
      cy += v_dl1;
    }
    cv::v_store_aligned(row_pgdl + h0, pgdl);
    cv::v_store_aligned(row_ngdl + h0, ngdl);
    cv::v_store_aligned(row_pgdo + h0, pgdo);
    cv::v_store_aligned(row_ngdo + h0, ngdo);
  }

  for (int h = 0; h < kLsrHeight; ++h) {
    const float g = w.global[h];
    const float pgdl = row_pgdl[h] * g, ngdl = row_ngdl[h] * g;
    const float pgdo = row_pgdo[h] * g, ngdo = row_ngdo[h] * g;
    const float pgdl2 = pgdl * pgdl, ngdl2 = ngdl * ngdl, pgdo2 = pgdo * pgdo, ngdo2 = ngdo * ngdo;
    // Each row feeds its own band and, attenuated, the bands above and below.
    auto add = [&](int band, float c) {
      pgdl_band[band] += c * pgdl;
      ngdl_band[band] += c * ngdl;
      pgdl2_band[band] += c * c * pgdl2;
      ngdl2_band[band] += c * c * ngdl2;
      pgdo_band[band] += c * pgdo;
      ngdo_band[band] += c * ngdo;
      pgdo2_band[band] += c * c * pgdo2;
      ngdo2_band[band] += c * c * ngdo2;
    };
    const int band = h / kBandWidth;
    const int in_band = h % kBandWidth;
    add(band, w.local[in_band + kBandWidth]);
    if (band - 1 >= 0) add(band - 1, w.local[in_band + 2 * kBandWidth]);
    if (band + 1 < kNumBands) add(band + 1, w.local[in_band]);
  }

  float desc[kNumBands * 8];
  const float inv_n2 = static_cast<float>(1.0 / (kBandWidth * 2.0));
  const float inv_n3 = static_cast<float>(1.0 / (kBandWidth * 3.0));
  for (int b = 0; b < kNumBands; ++b) {
    const float inv_n = (b == 0 || b == kNumBands - 1) ? inv_n2 : inv_n3;
    float* d = desc + 8 * b;
    float t = pgdl_band[b] * inv_n;
    d[0] = t;
    d[4] = std::sqrt(pgdl2_band[b] * inv_n - t * t);
    t = ngdl_band[b] * inv_n;
    d[1] = t;
    d[5] = std::sqrt(ngdl2_band[b] * inv_n - t * t);
    t = pgdo_band[b] * inv_n;
    d[2] = t;
    d[6] = std::sqrt(pgdo2_band[b] * inv_n - t * t);
    t = ngdo_band[b] * inv_n;
    d[3] = t;
    d[7] = std::sqrt(ngdo2_band[b] * inv_n - t * t);
  }
  // Means and standard deviations are normalised separately, then clipped at 0.4 against
  // non-linear illumination, then the whole vector is normalised again.
  float sum_m = 0, sum_s = 0;
  for (int b = 0; b < kNumBands; ++b) {
    const float* d = desc + 8 * b;
    sum_m += d[0] * d[0];
    sum_m += d[1] * d[1];
    sum_m += d[2] * d[2];
    sum_m += d[3] * d[3];
    sum_s += d[4] * d[4];
    sum_s += d[5] * d[5];
    sum_s += d[6] * d[6];
    sum_s += d[7] * d[7];
  }
  const float inv_m = 1 / std::sqrt(sum_m), inv_s = 1 / std::sqrt(sum_s);
  for (int b = 0; b < kNumBands; ++b) {
    float* d = desc + 8 * b;
    for (int i = 0; i < 4; ++i) d[i] = d[i] * inv_m;
    for (int i = 4; i < 8; ++i) d[i] = d[i] * inv_s;
  }
  float sum = 0;
  for (float& v : desc) {
    if (v > 0.4f) v = 0.4f;
  }
  for (float v : desc) sum += v * v;
  const float inv = 1 / std::sqrt(sum);
  for (float& v : desc) v = v * inv;

  for (int c = 0; c < 32; ++c) {
    const float* f1 = desc + 8 * kBandPairs[c][0];
    const float* f2 = desc + 8 * kBandPairs[c][1];
    uint8_t byte = 0;
    for (int i = 0; i < 8; ++i) {
      if (f1[i] > f2[i]) byte = static_cast<uint8_t>(byte | (1u << i));
    }
    out[c] = byte;
  }
}

}  // namespace

// The gradients LBD is defined on; the edge-chain detector reuses them so Sobel runs once.
void ComputeGradients(const cv::Mat& image, cv::Mat* blurred, cv::Mat* dx, cv::Mat* dy) {
  cv::GaussianBlur(image, *blurred, cv::Size(5, 5), 1.0);
  cv::spatialGradient(*blurred, *dx, *dy, 3);
}

// LBD of every line, row i for line i.
void LbdFromGradients(const cv::Mat& dx, const cv::Mat& dy, const LineFeatures& lines,
                      cv::Mat* descriptors) {
  descriptors->create(static_cast<int>(lines.size()), 32, CV_8UC1);
  for (int i = 0; i < static_cast<int>(lines.size()); ++i) {
    LbdOfLine(dx, dy, lines[i], descriptors->ptr<uint8_t>(i));
  }
}

}  // namespace line_internal

void ComputeLbdDescriptors(const cv::Mat& image, const LineFeatures& lines, cv::Mat* descriptors) {
  if (lines.empty() || image.empty()) {
    *descriptors = cv::Mat(0, 32, CV_8UC1);
    return;
  }
  if (image.type() != CV_8UC1) {
    throw InputError("ComputeLbdDescriptors: image must be CV_8UC1, got type " +
                     std::to_string(image.type()));
  }
  cv::Mat blurred, dx, dy;
  line_internal::ComputeGradients(image, &blurred, &dx, &dy);
  line_internal::LbdFromGradients(dx, dy, lines, descriptors);
}

}  // namespace pl_slam
