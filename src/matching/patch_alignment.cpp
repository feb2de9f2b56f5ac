#include "pl_slam/matching/patch_alignment.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace pl_slam {
namespace {

// Bilinear intensity at (x, y); the caller keeps (x, y) at least one pixel inside the image.
inline double Sample(const cv::Mat& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  const uint8_t* r0 = image.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1) + x0;
  return (1.0 - ay) * ((1.0 - ax) * r0[0] + ax * r0[1]) + ay * ((1.0 - ax) * r1[0] + ax * r1[1]);
}

// True when a square of half-size `half` around (x, y) can be sampled bilinearly.
inline bool Inside(const cv::Mat& image, double x, double y, double half) {
  return x - half >= 0.0 && y - half >= 0.0 && x + half + 1.0 < image.cols &&
         y + half + 1.0 < image.rows;
}

}  // namespace

std::vector<uint8_t> TakePatch(const cv::Mat& image, const Eigen::Vector2d& uv) {
  constexpr int h = kStoredPatch / 2;
  std::vector<uint8_t> patch;
  if (image.empty() || image.type() != CV_8UC1 || !Inside(image, uv.x(), uv.y(), h)) return patch;
  patch.resize(kStoredPatch * kStoredPatch);
  for (int dy = -h; dy <= h; ++dy)
    for (int dx = -h; dx <= h; ++dx)
      patch[(dy + h) * kStoredPatch + dx + h] = static_cast<uint8_t>(
          std::lround(std::clamp(Sample(image, uv.x() + dx, uv.y() + dy), 0.0, 255.0)));
  return patch;
}

bool AlignPatch(const std::vector<uint8_t>& patch, const cv::Mat& image, const Eigen::Vector2d& uv,
                double max_offset, Eigen::Vector2d* offset) {
  constexpr int h = kAlignPatch / 2, n = kAlignPatch * kAlignPatch, kIterations = 10;
  if (patch.size() != static_cast<size_t>(kStoredPatch * kStoredPatch) || image.empty() ||
      image.type() != CV_8UC1)
    return false;
  // Template (zero mean) and its gradients, from the stored patch's inner square.
  double t[n], gx[n], gy[n];
  auto at = [&patch](int x, int y) {  // stored-patch coordinates, centre at (h + 1, h + 1)
    return static_cast<double>(patch[y * kStoredPatch + x]);
  };
  double mean_t = 0.0, mean_gx = 0.0, mean_gy = 0.0;
  for (int y = 0; y < kAlignPatch; ++y)
    for (int x = 0; x < kAlignPatch; ++x) {
      const int i = y * kAlignPatch + x;
      t[i] = at(x + 1, y + 1);
      gx[i] = 0.5 * (at(x + 2, y + 1) - at(x, y + 1));
      gy[i] = 0.5 * (at(x + 1, y + 2) - at(x + 1, y));
      mean_t += t[i];
      mean_gx += gx[i];
      mean_gy += gy[i];
    }
  mean_t /= n;
  mean_gx /= n;
  mean_gy /= n;
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  double var_t = 0.0;
  for (int i = 0; i < n; ++i) {
    t[i] -= mean_t;
    gx[i] -= mean_gx;
    gy[i] -= mean_gy;
    var_t += t[i] * t[i];
    H(0, 0) += gx[i] * gx[i];
    H(0, 1) += gx[i] * gy[i];
    H(1, 1) += gy[i] * gy[i];
  }
  H(1, 0) = H(0, 1);
  // Both directions must be fixed: the smaller eigenvalue of the structure tensor above what
  // the 8-bit rounding of a flat patch gives (a gradient of 0.5 grey levels per pixel).
  const double tr = H.trace(), det = H.determinant();
  const double min_eig = 0.5 * tr - std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
  if (!(min_eig > 0.25 * n) || !(var_t > 0.0)) return false;
  const Eigen::Matrix2d H_inv = H.inverse();

  Eigen::Vector2d d = Eigen::Vector2d::Zero();
  double v[n];
  bool converged = false;
  for (int iter = 0; iter < kIterations; ++iter) {
    const double cx = uv.x() + d.x(), cy = uv.y() + d.y();
    if (!Inside(image, cx, cy, h)) return false;
    double mean_v = 0.0;
    for (int y = 0; y < kAlignPatch; ++y)
      for (int x = 0; x < kAlignPatch; ++x) {
        const int i = y * kAlignPatch + x;
        v[i] = Sample(image, cx + x - h, cy + y - h);
        mean_v += v[i];
      }
    mean_v /= n;
    // The image patch scaled to the template's contrast: exposure may differ between views.
    double var_v = 0.0;
    for (int i = 0; i < n; ++i) var_v += (v[i] - mean_v) * (v[i] - mean_v);
    if (!(var_v > 0.0)) return false;
    const double gain = std::sqrt(var_t / var_v);
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (int i = 0; i < n; ++i) {
      const double r = gain * (v[i] - mean_v) - t[i];
      b.x() += gx[i] * r;
      b.y() += gy[i] * r;
    }
    // Inverse compositional: the template moves by delta, so the image position by -delta.
    const Eigen::Vector2d delta = H_inv * b;
    d -= delta;
    if (d.norm() > max_offset) return false;
    if (delta.norm() < 5e-3) {
      converged = true;
      break;
    }
  }
  if (!converged) return false;
  // Final check: the aligned patch must look like the template.
  const double cx = uv.x() + d.x(), cy = uv.y() + d.y();
  if (!Inside(image, cx, cy, h)) return false;
  double mean_v = 0.0;
  for (int y = 0; y < kAlignPatch; ++y)
    for (int x = 0; x < kAlignPatch; ++x) {
      v[y * kAlignPatch + x] = Sample(image, cx + x - h, cy + y - h);
      mean_v += v[y * kAlignPatch + x];
    }
  mean_v /= n;
  double cross = 0.0, var_v = 0.0;
  for (int i = 0; i < n; ++i) {
    cross += (v[i] - mean_v) * t[i];
    var_v += (v[i] - mean_v) * (v[i] - mean_v);
  }
  if (!(var_v > 0.0) || cross / std::sqrt(var_t * var_v) < 0.8) return false;
  *offset = d;
  return true;
}

double PatchWarp(const StereoCamera& cam, const SE3& T_cur_ref, const Eigen::Vector2d& uv_ref,
                 double z_ref) {
  auto map_px = [&](const Eigen::Vector2d& uv, Eigen::Vector2d* out) {
    const Eigen::Vector3d p =
        T_cur_ref * Eigen::Vector3d((uv.x() - cam.cx) / cam.fx * z_ref,
                                    (uv.y() - cam.cy) / cam.fy * z_ref, z_ref);
    if (p.z() <= 1e-6) return false;
    *out = cam.Project(p);
    return true;
  };
  Eigen::Vector2d xp, xm, yp, ym;
  if (!map_px(uv_ref + Eigen::Vector2d(1, 0), &xp) ||
      !map_px(uv_ref - Eigen::Vector2d(1, 0), &xm) ||
      !map_px(uv_ref + Eigen::Vector2d(0, 1), &yp) || !map_px(uv_ref - Eigen::Vector2d(0, 1), &ym))
    return std::numeric_limits<double>::infinity();
  Eigen::Matrix2d A;
  A.col(0) = 0.5 * (xp - xm);
  A.col(1) = 0.5 * (yp - ym);
  // A rotation is a warp too: compare A with the identity, not only its singular values.
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(A);
  const double stretch =
      std::max(std::abs(svd.singularValues()(0) - 1.0), std::abs(svd.singularValues()(1) - 1.0));
  const double turn = std::abs(std::atan2(A(1, 0) - A(0, 1), A(0, 0) + A(1, 1)));
  return std::max(stretch, turn);
}

}  // namespace pl_slam
