#include "pl_slam/sim/texture.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace pl_slam::sim {
namespace {

// Levels smaller than this are not worth building: a surface that small on screen is a few
// pixels, and pyrDown of a 1-texel-wide image would only repeat it.
constexpr int kMinLevelSize = 4;

}  // namespace

Texture::Texture(const cv::Mat& base) {
  if (base.empty() || base.channels() != 1) {
    throw std::invalid_argument("Texture: base image must be a non-empty single-channel image");
  }
  cv::Mat level0;
  base.convertTo(level0, CV_32F);
  levels_.push_back(level0);
  while (std::min(levels_.back().cols, levels_.back().rows) >= 2 * kMinLevelSize) {
    cv::Mat next;
    cv::pyrDown(levels_.back(), next);
    levels_.push_back(next);
  }
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    const cv::Mat& m = levels_[l];
    LevelView v;
    v.data = m.ptr<float>(0);
    v.stride = m.step1();
    v.max_x = m.cols - 1;
    v.max_y = m.rows - 1;
    v.inv_scale = 1.0f / static_cast<float>(1 << l);
    views_.push_back(v);
  }
}

namespace {

// floor() for values well inside the int range, without a libm call.
inline int FloorToInt(float x) {
  const int i = static_cast<int>(x);
  return i - (static_cast<float>(i) > x);
}

// log2(x) for normal x > 0 to within 0.008: the level of detail only chooses how much to blur,
// so libm's exact log2 (a noticeable share of the per-pixel time) is not needed. The quadratic
// in the mantissa is exact at 1 and 2, so the result is continuous across exponents.
inline float FastLog2(float x) {
  uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  const float exponent = static_cast<float>(static_cast<int>(bits >> 23) - 127);
  bits = (bits & 0x007FFFFFu) | 0x3F800000u;  // mantissa in [1, 2)
  float m;
  std::memcpy(&m, &bits, sizeof m);
  return exponent + ((-0.3466f * m + 2.0398f) * m - 1.6932f);
}

}  // namespace

float Texture::SampleLevel(int l, double x, double y) const {
  const LevelView& m = views_[l];
  // pyrDown centres output texel i on input texel 2i, so level-l texel i is centred at base
  // coordinate 2^l * i + 0.5. Using that exact mapping keeps features from drifting when
  // the level of detail changes with distance. Coordinates far outside are clamped first so
  // the int conversion cannot overflow.
  const float xl = static_cast<float>((std::clamp(x, -1e6, 1e6) - 0.5)) * m.inv_scale;
  const float yl = static_cast<float>((std::clamp(y, -1e6, 1e6) - 0.5)) * m.inv_scale;
  int x0 = FloorToInt(xl);
  int y0 = FloorToInt(yl);
  const float ax = xl - static_cast<float>(x0);
  const float ay = yl - static_cast<float>(y0);
  int x1 = x0 + 1;
  int y1 = y0 + 1;
  if (x0 < 0 || x1 > m.max_x) {
    x0 = std::clamp(x0, 0, m.max_x);
    x1 = std::clamp(x1, 0, m.max_x);
  }
  if (y0 < 0 || y1 > m.max_y) {
    y0 = std::clamp(y0, 0, m.max_y);
    y1 = std::clamp(y1, 0, m.max_y);
  }
  const float* r0 = m.data + static_cast<std::size_t>(y0) * m.stride;
  const float* r1 = m.data + static_cast<std::size_t>(y1) * m.stride;
  const float top = r0[x0] + ax * (r0[x1] - r0[x0]);
  const float bottom = r1[x0] + ax * (r1[x1] - r1[x0]);
  return top + ay * (bottom - top);
}

float Texture::Sample(double x, double y, double lod) const {
  const int top = num_levels() - 1;
  if (!(lod > 0.0)) return SampleLevel(0, x, y);  // also catches NaN
  if (lod >= top) return SampleLevel(top, x, y);
  const int l0 = static_cast<int>(lod);
  const float w = static_cast<float>(lod - l0);
  const float a = SampleLevel(l0, x, y);
  const float b = SampleLevel(l0 + 1, x, y);
  return a + w * (b - a);
}

float Texture::SampleFootprint(double x, double y, double dxu, double dyu, double dxv,
                               double dyv) const {
  const double lu2 = dxu * dxu + dyu * dyu;
  const double lv2 = dxv * dxv + dyv * dyv;
  const bool u_major = lu2 >= lv2;
  const double major2 = u_major ? lu2 : lv2;
  const double minor2 = u_major ? lv2 : lu2;
  // Taps along the long axis, each filtering a major / taps wide piece of the footprint.
  // Rounding (not ceil) the axis ratio keeps near-isotropic footprints, most of the image, at
  // one tap; they are then filtered at most 1.5 times wider than ideal along the short axis.
  int taps = 1;
  if (major2 > 1.0 && major2 > 2.25 * minor2) {
    const double ratio = minor2 > 0.0 ? std::sqrt(major2 / minor2) : kMaxAnisotropy;
    taps = std::min(kMaxAnisotropy, static_cast<int>(ratio + 0.5));
  }
  const float footprint2 = static_cast<float>(major2 / (taps * taps));
  const double lod = footprint2 > 1.0f ? 0.5f * FastLog2(footprint2) : 0.0;
  if (taps == 1) return Sample(x, y, lod);
  const double ax = u_major ? dxu : dxv;
  const double ay = u_major ? dyu : dyv;
  float sum = 0.0f;
  for (int k = 0; k < taps; ++k) {
    const double f = (k + 0.5) / taps - 0.5;
    sum += Sample(x + f * ax, y + f * ay, lod);
  }
  return sum / static_cast<float>(taps);
}

}  // namespace pl_slam::sim
