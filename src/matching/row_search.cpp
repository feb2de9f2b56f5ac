#include "row_search.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/imgproc.hpp>

namespace pl_slam {
namespace match_internal {

void RightSums::Ensure(const cv::Mat& right) {
  if (sum.empty()) cv::integral(right, sum, sqsum, CV_32S, CV_64F);
}

bool SearchRow(const cv::Mat& left, const cv::Mat& right, RightSums* sums, int u0, int v0, int c0,
               int c1, double min_zncc, double margin, double* ur) {
  constexpr int kHalf = kStereoPatchHalf, kN = 2 * kHalf + 1, kMaxRange = 1024;
  if (v0 - kHalf < 0 || v0 + kHalf >= left.rows || u0 - kHalf < 0 || u0 + kHalf >= left.cols)
    return false;
  c0 = std::max(c0, kHalf);
  c1 = std::min(c1, right.cols - 1 - kHalf);
  const int n = c1 - c0 + 1;
  if (n < 5 || n > kMaxRange) return false;
  float lz[kN * kN];
  double mean = 0.0;
  for (int dy = 0; dy < kN; ++dy) {
    const uint8_t* lp = left.ptr<uint8_t>(v0 - kHalf + dy) + u0 - kHalf;
    for (int dx = 0; dx < kN; ++dx) mean += lz[dy * kN + dx] = lp[dx];
  }
  mean /= kN * kN;
  double var_l = 0.0;
  for (float& x : lz) {
    x = static_cast<float>(x - mean);
    var_l += static_cast<double>(x) * x;
  }
  if (var_l < 1e-6) return false;
  // sum(lz * r) per column: lz has zero mean, so the right patch's mean drops out. One
  // vectorisable pass over the columns per patch pixel.
  float cross[kMaxRange];
  std::fill(cross, cross + n, 0.f);
  for (int dy = 0; dy < kN; ++dy) {
    const uint8_t* rp = right.ptr<uint8_t>(v0 - kHalf + dy) + c0 - kHalf;
    for (int dx = 0; dx < kN; ++dx) {
      const float w = lz[dy * kN + dx];
      const uint8_t* r = rp + dx;
      for (int c = 0; c < n; ++c) cross[c] += w * static_cast<float>(r[c]);
    }
  }
  sums->Ensure(right);
  const int* s0 = sums->sum.ptr<int>(v0 - kHalf) + c0 - kHalf;
  const int* s1 = sums->sum.ptr<int>(v0 + kHalf + 1) + c0 - kHalf;
  const double* q0 = sums->sqsum.ptr<double>(v0 - kHalf) + c0 - kHalf;
  const double* q1 = sums->sqsum.ptr<double>(v0 + kHalf + 1) + c0 - kHalf;
  int best = -1;
  double best_z = -2.0;
  double z[kMaxRange];
  for (int c = 0; c < n; ++c) {
    const double sr = static_cast<double>(s1[c + kN] - s1[c] - s0[c + kN] + s0[c]);
    const double srr = q1[c + kN] - q1[c] - q0[c + kN] + q0[c];
    const double var_r = srr - sr * sr / (kN * kN);
    z[c] = var_r > 1e-6 ? cross[c] / std::sqrt(var_l * var_r) : -1.0;
    if (z[c] > best_z) {
      best_z = z[c];
      best = c;
    }
  }
  if (best_z < min_zncc || best == 0 || best == n - 1) return false;
  // A well-placed peak: 3 px to either side the correlation has fallen (a patch on a straight
  // edge slides along it and does not fall).
  constexpr int kLocal = 3;
  constexpr double kLocalDrop = 0.03;
  if ((best - kLocal >= 0 && z[best - kLocal] > best_z - kLocalDrop) ||
      (best + kLocal < n && z[best + kLocal] > best_z - kLocalDrop))
    return false;
  // A unique peak: its own slopes (the columns over which the correlation keeps falling away
  // from it) are no rivals, however slowly a blurred corner's correlation falls; every column
  // past them is, and must stay margin below the peak.
  int lo = best, hi = best;
  while (lo > 0 && z[lo - 1] <= z[lo]) --lo;
  while (hi < n - 1 && z[hi + 1] <= z[hi]) ++hi;
  for (int c = 0; c < n; ++c)
    if ((c < lo || c > hi) && z[c] > best_z - margin) return false;
  const double denom = z[best - 1] - 2.0 * z[best] + z[best + 1];
  const double delta =
      denom < 0.0 ? std::clamp(0.5 * (z[best - 1] - z[best + 1]) / denom, -0.5, 0.5) : 0.0;
  *ur = c0 + best + delta;
  return true;
}

}  // namespace match_internal
}  // namespace pl_slam
