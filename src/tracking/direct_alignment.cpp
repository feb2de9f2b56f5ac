#include "pl_slam/tracking/direct_alignment.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {
namespace {

using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix8d = Eigen::Matrix<double, 8, 8>;

constexpr int kHalfWindow = 3;  // stereo correlation window 7 x 7
// A row match must explain half of the window's variance (energy), and every other position
// 3 px away or more must cost 1 / 0.8 times more (plus 5 % of the energy, for noise).
constexpr float kMaxCostRatio = 0.5f;
constexpr float kUniqueness = 0.8f;
constexpr float kCostFloor = 0.05f;
constexpr float kMinGradient = 0.5f;    // floor of the reference gradient threshold, grey/px
constexpr int kMaxIterations = 12;      // Gauss-Newton iterations per pyramid level
constexpr double kHuber = 1.345;        // Huber threshold, robust sigmas
constexpr double kMinSigma = 0.5;       // floor of the robust residual sigma, grey levels
constexpr double kMinDepth = 0.05;      // nearer projections are not used, m
constexpr double kMaxBrightness = 0.5;  // |gain - 1| beyond this: the brightness fit failed
constexpr int kSaturated = 250;         // grey levels from here on may be clipped

// The image as float, smoothed as every level is before sampling (noise down, basin wider).
cv::Mat Smoothed(const cv::Mat& image) {
  cv::Mat f;
  image.convertTo(f, CV_32F);
  cv::GaussianBlur(f, f, cv::Size(5, 5), 1.0);
  return f;
}

std::vector<cv::Mat> Pyramid(const cv::Mat& image, int levels) {
  std::vector<cv::Mat> pyr{Smoothed(image)};
  for (int l = 1; l < levels; ++l) {
    if (pyr.back().cols < 16 || pyr.back().rows < 16) break;
    cv::Mat down;
    cv::pyrDown(pyr.back(), down);
    pyr.push_back(down);
  }
  return pyr;
}

// Intensity gradients in grey levels per pixel.
void Gradients(const cv::Mat& f, cv::Mat* gx, cv::Mat* gy) {
  cv::Sobel(f, *gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(f, *gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
}

// Bilinear sample; (x, y) must be inside [0, cols - 1) x [0, rows - 1).
inline float Sample(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  const float* r0 = m.ptr<float>(y0) + x0;
  const float* r1 = m.ptr<float>(y0 + 1) + x0;
  return (1.f - ay) * ((1.f - ax) * r0[0] + ax * r0[1]) + ay * ((1.f - ax) * r1[0] + ax * r1[1]);
}

// The camera of pyramid level l: cv::pyrDown's pixel i is level l-1's pixel 2i, u_l = u / 2^l.
struct LevelCamera {
  double fx, fy, cx, cy;
  int cols, rows;
};

LevelCamera AtLevel(const StereoCamera& cam, int level, const cv::Mat& image) {
  const double s = std::ldexp(1.0, -level);
  return {cam.fx * s, cam.fy * s, cam.cx * s, cam.cy * s, image.cols, image.rows};
}

// The disparity of left pixel (x, y): the zero-mean SSD of a 7 x 7 window along the right
// image's row (smoothed float images), whose best must be clearly better than every position
// 3 px or more away; false when there is no unique minimum.
bool RowDisparity(const cv::Mat& left, const cv::Mat& right, int x, int y, int max_disparity,
                  std::vector<float>* costs, double* disparity) {
  constexpr int w = 2 * kHalfWindow + 1;
  const int lo = std::max(kHalfWindow, x - max_disparity);  // right-image centre range
  const int hi = x - 1;
  if (hi - lo < 4) return false;
  float t[w * w];
  float t_mean = 0.f;
  for (int r = 0; r < w; ++r) {
    const float* p = left.ptr<float>(y - kHalfWindow + r) + x - kHalfWindow;
    for (int c = 0; c < w; ++c) t_mean += (t[r * w + c] = p[c]);
  }
  t_mean /= w * w;
  float t_energy = 0.f;
  for (float& v : t) {
    v -= t_mean;
    t_energy += v * v;
  }
  const int n = hi - lo + 1;
  costs->assign(n, 0.f);
  // Per-column sums of the strip's values and squares, so that each window's sums are 7 adds
  // (the zero-mean cost does not change when the strip is shifted by the template's mean);
  // the cross term with the (zero-mean) template is the only 7 x 7 product.
  const int first = lo - kHalfWindow, cols = n + w - 1;
  thread_local std::vector<float> col_sum, col_sq;
  col_sum.assign(cols, 0.f);
  col_sq.assign(cols, 0.f);
  for (int r = 0; r < w; ++r) {
    const float* p = right.ptr<float>(y - kHalfWindow + r) + first;
    for (int c = 0; c < cols; ++c) {
      const float v = p[c] - t_mean;  // shifted: the sums stay small (float precision)
      col_sum[c] += v;
      col_sq[c] += v * v;
    }
  }
  const float* rows[w];
  for (int r = 0; r < w; ++r) rows[r] = right.ptr<float>(y - kHalfWindow + r) + first;
  for (int k = 0; k < n; ++k) {
    float sum = 0.f, sq = 0.f, cross = 0.f;
    for (int c = 0; c < w; ++c) {
      sum += col_sum[k + c];
      sq += col_sq[k + c];
    }
    for (int r = 0; r < w; ++r) {
      const float* p = rows[r] + k;
      const float* tr = t + r * w;
      for (int c = 0; c < w; ++c) cross += tr[c] * p[c];
    }
    // sum((t - t_mean) - (p - p_mean))^2 = T - 2 sum(t' p) + sum(p^2) - sum(p)^2 / n.
    (*costs)[k] = t_energy - 2.f * cross + sq - sum * sum / (w * w);
  }
  const float* s = costs->data();
  int best = 0;
  for (int k = 1; k < n; ++k)
    if (s[k] < s[best]) best = k;
  // The window must carry structure well above its noise, and no other position may fit
  // nearly as well (repeated or one-directional structure has no single disparity).
  if (!(s[best] < kMaxCostRatio * t_energy)) return false;
  for (int k = 0; k < n; ++k)
    if (std::abs(k - best) >= 3 && s[k] * kUniqueness < s[best] + kCostFloor * t_energy)
      return false;
  double offset = 0.0;
  if (best > 0 && best + 1 < n) {
    const double a = s[best - 1], b = s[best], c = s[best + 1];
    const double den = a - 2.0 * b + c;
    if (den > 0.0) offset = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
  }
  *disparity = x - (lo + best + offset);
  return true;
}

// One level's Huber cost at (T, gain, bias) (sigma fixed by the caller), the number of points
// inside the image and, when asked for, the Gauss-Newton system H, g of [pose; gain; bias].
struct Linearisation {
  Matrix8d H = Matrix8d::Zero();
  Vector8d g = Vector8d::Zero();
  double cost = 0.0;
  int pixels = 0;
};

class LevelProblem {
 public:
  LevelProblem(const DirectReference& ref, int level, const LevelCamera& cam, const cv::Mat& img,
               const cv::Mat& gx, const cv::Mat& gy)
      : ref_(ref), level_(level), cam_(cam), img_(img), gx_(gx), gy_(gy) {}

  /// Residuals r = I_cur(pi(T X)) - (gain I_ref + bias) of the points in view.
  void Residuals(const SE3& T, double gain, double bias, std::vector<double>* r) const {
    r->clear();
    for (std::size_t i = 0; i < ref_.points.size(); ++i) {
      double u, v;
      Eigen::Vector3d X;
      if (!Project(T, i, &X, &u, &v)) continue;
      const float i1 = Sample(img_, u, v);
      if (i1 >= kSaturated) continue;  // clipped: no brightness to compare
      r->push_back(i1 - (gain * ref_.intensity[level_][i] + bias));
    }
  }

  /// `jacobians`: with H and g. `noise_free`: the Jacobians from the reference gradient with
  /// its noise level subtracted from each component, for the covariance: noise alone would
  /// otherwise lend information to directions the image does not fix (along an edge).
  Linearisation Linearise(const SE3& T, double gain, double bias, double sigma, bool jacobians,
                          bool noise_free = false) const {
    Linearisation out;
    const double k = kHuber * sigma;
    for (std::size_t i = 0; i < ref_.points.size(); ++i) {
      double u, v;
      Eigen::Vector3d X;
      if (!Project(T, i, &X, &u, &v)) continue;
      const double i0 = ref_.intensity[level_][i];
      const float i1 = Sample(img_, u, v);
      if (i1 >= kSaturated) continue;  // clipped: no brightness to compare
      const double r = i1 - (gain * i0 + bias);
      const double a = std::abs(r);
      out.cost += a <= k ? 0.5 * r * r : k * (a - 0.5 * k);
      ++out.pixels;
      if (!jacobians) continue;
      const double w = a <= k ? 1.0 : k / a;
      const double iz = 1.0 / X.z(), x = X.x() * iz, y = X.y() * iz;
      // The mean of both images' gradients (efficient second-order minimisation, Benhimane
      // and Malis 2004): a wider basin than the current image's alone.
      const Eigen::Vector2f& g0 = ref_.gradient[level_][i];
      double dx, dy;
      if (noise_free) {
        const double n = 3.0 * ref_.gradient_noise;
        auto shrink = [n](double g) { return std::copysign(std::max(0.0, std::abs(g) - n), g); };
        dx = gain * shrink(g0.x()) * cam_.fx;
        dy = gain * shrink(g0.y()) * cam_.fy;
      } else {
        dx = 0.5 * (Sample(gx_, u, v) + gain * g0.x()) * cam_.fx;
        dy = 0.5 * (Sample(gy_, u, v) + gain * g0.y()) * cam_.fy;
      }
      Vector8d J;
      // d I(pi(Exp(d) X)) / d d = grad I * d pi / dX * [I, -Hat(X)] (motion_estimator.cpp).
      J << dx * iz, dy * iz, -(dx * x + dy * y) * iz, -dx * x * y - dy * (1.0 + y * y),
          dx * (1.0 + x * x) + dy * x * y, -dx * y + dy * x, -i0, -1.0;
      out.H.noalias() += w * J * J.transpose();
      out.g.noalias() += w * r * J;
    }
    return out;
  }

 private:
  bool Project(const SE3& T, std::size_t i, Eigen::Vector3d* X, double* u, double* v) const {
    *X = T * ref_.points[i];
    if (X->z() < kMinDepth) return false;
    *u = cam_.fx * X->x() / X->z() + cam_.cx;
    *v = cam_.fy * X->y() / X->z() + cam_.cy;
    return *u >= 1.0 && *v >= 1.0 && *u < cam_.cols - 2.0 && *v < cam_.rows - 2.0;
  }

  const DirectReference& ref_;
  int level_;
  LevelCamera cam_;
  const cv::Mat& img_;
  const cv::Mat& gx_;
  const cv::Mat& gy_;
};

double RobustSigma(std::vector<double> r) {
  if (r.empty()) return kMinSigma;
  for (double& x : r) x = std::abs(x);
  auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
  std::nth_element(r.begin(), mid, r.end());
  return std::max(kMinSigma, 1.4826 * *mid);
}

void CheckImage(const StereoCamera& camera, const cv::Mat& image, const char* what) {
  if (image.type() != CV_8UC1 || image.cols != camera.width || image.rows != camera.height) {
    std::ostringstream os;
    os << "direct alignment: " << what << " image must be CV_8UC1 " << camera.width << "x"
       << camera.height << ", got type " << image.type() << " " << image.cols << "x" << image.rows;
    throw InputError(os.str());
  }
}

}  // namespace

std::string DirectAlignmentOptions::Validate() const {
  std::string e;
  if (!(e = CheckRange("max_pixels", max_pixels, 10, 100000)).empty()) return e;
  if (!(e = CheckRange("min_gradient_sigmas", min_gradient_sigmas, 0.0, 100.0, true)).empty())
    return e;
  if (!(e = CheckRange("levels", levels, 1, 8)).empty()) return e;
  if (!(e = CheckRange("min_pixels", min_pixels, 10, 100000)).empty()) return e;
  if (!(e = CheckRange("max_residual", max_residual, 0.0, 255.0, true)).empty()) return e;
  if (!(e = CheckRange("max_rotation_sigma_deg", max_rotation_sigma_deg, 0.0, 90.0, true)).empty())
    return e;
  return {};
}

DirectReference BuildDirectReference(const StereoCamera& camera, const cv::Mat& left,
                                     const cv::Mat& right, double max_disparity,
                                     const DirectAlignmentOptions& options) {
  CheckImage(camera, left, "left");
  CheckImage(camera, right, "right");
  DirectReference ref;
  ref.pyramid = Pyramid(left, options.levels);
  const cv::Mat& l0 = ref.pyramid[0];
  const cv::Mat r0 = Smoothed(right);
  cv::Mat gx, gy;
  Gradients(l0, &gx, &gy);

  const int border = kHalfWindow + 1;
  // Saturated pixels and their neighbours are left out of the noise estimate and the
  // selection: flat at 255 they would make the noise look absent, and a clipped highlight's
  // smooth surroundings (lighting, vignetting) would pass for edges.
  cv::Mat saturated;
  cv::threshold(left, saturated, kSaturated - 1, 255, cv::THRESH_BINARY);
  cv::dilate(saturated, saturated,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * border + 1, 2 * border + 1)));
  // The gradient threshold in multiples of the noise's standard deviation in gx, from the
  // lower quartile of |gx| (0.319 sigma for noise alone; texture raises it less than the
  // median): a fixed threshold would depend on the exposure and the camera.
  std::vector<float> sample;
  sample.reserve(gx.total() / 16 + 1);
  for (int y = border; y < gx.rows - border; y += 4) {
    const float* px = gx.ptr<float>(y);
    const uint8_t* sat = saturated.ptr<uint8_t>(y);
    for (int x = border; x < gx.cols - border; x += 4)
      if (!sat[x]) sample.push_back(std::abs(px[x]));  // clipped areas have no noise to see
  }
  float quartile = 0.f;
  if (!sample.empty()) {
    auto q = sample.begin() + static_cast<std::ptrdiff_t>(sample.size() / 4);
    std::nth_element(sample.begin(), q, sample.end());
    quartile = *q;
  }
  ref.gradient_noise = quartile / 0.3186f;
  const float min_gradient =
      std::max(kMinGradient, static_cast<float>(options.min_gradient_sigmas) * ref.gradient_noise);
  // One candidate per cell: the strongest horizontal gradient (only those have a row
  // disparity). Eight times as many cells as pixels wanted: a sparse view's few edges then
  // still give a pixel every few pixels along them, and not every candidate finds a match.
  const int cell = std::max(
      3, static_cast<int>(std::lround(std::sqrt(l0.total() / (8.0 * options.max_pixels)))));
  struct Candidate {
    int x, y;
    float g;
  };
  std::vector<Candidate> candidates;
  for (int y0 = border; y0 < l0.rows - border; y0 += cell) {
    for (int x0 = border; x0 < l0.cols - border; x0 += cell) {
      Candidate best{0, 0, 0.f};
      for (int y = y0; y < std::min(y0 + cell, l0.rows - border); ++y) {
        const float* px = gx.ptr<float>(y);
        const uint8_t* sat = saturated.ptr<uint8_t>(y);
        for (int x = x0; x < std::min(x0 + cell, l0.cols - border); ++x) {
          const float g = std::abs(px[x]);
          if (g > best.g && !sat[x]) best = {x, y, g};
        }
      }
      if (best.g >= min_gradient) candidates.push_back(best);
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.g > b.g; });
  const int max_d = static_cast<int>(std::clamp(max_disparity, 8.0, 0.9 * l0.cols));
  std::vector<float> costs;
  for (const Candidate& c : candidates) {
    if (static_cast<int>(ref.points.size()) >= options.max_pixels) break;
    double d;
    if (!RowDisparity(l0, r0, c.x, c.y, max_d, &costs, &d)) continue;
    if (!(d + camera.doffs > 0.5)) continue;
    const Eigen::Vector3d X = camera.BackProject(c.x, c.y, d);
    if (!X.allFinite() || X.z() <= kMinDepth) continue;
    ref.points.push_back(X);
  }
  ref.intensity.resize(ref.pyramid.size());
  ref.gradient.resize(ref.pyramid.size());
  for (std::size_t l = 0; l < ref.pyramid.size(); ++l) {
    const LevelCamera cam = AtLevel(camera, static_cast<int>(l), ref.pyramid[l]);
    ref.intensity[l].reserve(ref.points.size());
    ref.gradient[l].reserve(ref.points.size());
    // Level 0's gradients were computed for the selection; the others get their own buffers
    // (never written through a header that shares level 0's data).
    cv::Mat lgx, lgy;
    if (l == 0) {
      lgx = gx;
      lgy = gy;
    } else {
      Gradients(ref.pyramid[l], &lgx, &lgy);
    }
    for (const Eigen::Vector3d& X : ref.points) {
      const double u = std::clamp(cam.fx * X.x() / X.z() + cam.cx, 0.0, cam.cols - 1.001);
      const double v = std::clamp(cam.fy * X.y() / X.z() + cam.cy, 0.0, cam.rows - 1.001);
      ref.intensity[l].push_back(Sample(ref.pyramid[l], u, v));
      ref.gradient[l].emplace_back(Sample(lgx, u, v), Sample(lgy, u, v));
    }
  }
  return ref;
}

DirectAlignmentResult AlignDirect(const StereoCamera& camera, const DirectReference& ref,
                                  const cv::Mat& cur_left, const SE3& prior,
                                  const DirectAlignmentOptions& options) {
  CheckImage(camera, cur_left, "current");
  DirectAlignmentResult out;
  out.T_cur_ref = prior;
  if (static_cast<int>(ref.points.size()) < options.min_pixels) {
    out.failure = "only " + std::to_string(ref.points.size()) + " reference pixels with depth";
    return out;
  }
  const std::vector<cv::Mat> pyr = Pyramid(cur_left, static_cast<int>(ref.pyramid.size()));
  const int levels = static_cast<int>(std::min(pyr.size(), ref.pyramid.size()));
  SE3 T = prior;
  double gain = 1.0, bias = 0.0;
  double sigma = kMinSigma;
  std::vector<double> residuals;
  cv::Mat gx, gy;  // after the loop: level 0's, for the final linearisation
  for (int l = levels - 1; l >= 0; --l) {
    Gradients(pyr[l], &gx, &gy);
    const LevelProblem problem(ref, l, AtLevel(camera, l, pyr[l]), pyr[l], gx, gy);
    double lambda = 1e-4;
    for (int it = 0; it < kMaxIterations; ++it) {
      problem.Residuals(T, gain, bias, &residuals);
      if (static_cast<int>(residuals.size()) < options.min_pixels) {
        out.failure = "only " + std::to_string(residuals.size()) + " reference pixels in view";
        return out;
      }
      sigma = RobustSigma(residuals);
      const Linearisation lin = problem.Linearise(T, gain, bias, sigma, true);
      bool stepped = false;
      for (int attempt = 0; attempt < 6 && !stepped; ++attempt) {
        Matrix8d A = lin.H;
        A.diagonal() += lambda * lin.H.diagonal().cwiseMax(1e-9);
        const Vector8d step = A.ldlt().solve(-lin.g);
        if (!step.allFinite()) break;
        const SE3 T_new = SE3::Exp(step.head<6>()) * T;
        const Linearisation trial =
            problem.Linearise(T_new, gain + step(6), bias + step(7), sigma, false);
        // Mean cost over the points in view, which must not mostly leave it.
        if (trial.pixels >= lin.pixels / 2 && trial.pixels > 0 &&
            trial.cost / trial.pixels < lin.cost / lin.pixels) {
          T = T_new;
          gain += step(6);
          bias += step(7);
          lambda = std::max(1e-8, lambda * 0.5);
          stepped = true;
          if (step.head<6>().norm() < 1e-6) it = kMaxIterations;  // converged
        } else {
          lambda *= 4.0;
        }
      }
      if (!stepped) break;
    }
  }
  // The final linearisation at full resolution: the covariance of the pose with the
  // brightness parameters marginalised out.
  const LevelProblem problem(ref, 0, AtLevel(camera, 0, pyr[0]), pyr[0], gx, gy);
  problem.Residuals(T, gain, bias, &residuals);
  sigma = RobustSigma(residuals);
  const Linearisation last = problem.Linearise(T, gain, bias, sigma, true, true);
  out.T_cur_ref = T;
  out.pixels = last.pixels;
  out.residual = sigma;
  if (last.pixels < options.min_pixels) {
    out.failure = "only " + std::to_string(last.pixels) + " reference pixels in view";
    return out;
  }
  if (sigma > options.max_residual) {
    std::ostringstream os;
    os << "residual " << sigma << " grey levels > max_residual " << options.max_residual;
    out.failure = os.str();
    return out;
  }
  if (std::abs(gain - 1.0) > kMaxBrightness) {
    out.failure = "brightness change out of range";
    return out;
  }
  const Matrix6d Hpp = last.H.topLeftCorner<6, 6>();
  const Eigen::Matrix<double, 6, 2> Hpb = last.H.topRightCorner<6, 2>();
  const Eigen::Matrix2d Hbb = last.H.bottomRightCorner<2, 2>();
  const Matrix6d schur = Hpp - Hpb * Hbb.ldlt().solve(Hpb.transpose());
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(schur);
  if (!(eig.eigenvalues()(0) > 1e-12 * std::max(1.0, eig.eigenvalues()(5)))) {
    out.failure = "motion not constrained by the image";
    return out;
  }
  out.covariance = sigma * sigma * schur.inverse();
  if (!T.IsFinite() || !out.covariance.allFinite()) {
    out.failure = "no finite estimate";
    return out;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rot(
      out.covariance.bottomRightCorner<3, 3>());
  const double rotation_sigma_deg = std::sqrt(std::max(0.0, rot.eigenvalues()(2))) * 180.0 / M_PI;
  if (rotation_sigma_deg > options.max_rotation_sigma_deg) {
    std::ostringstream os;
    os << "rotation not determined by the image: standard deviation " << rotation_sigma_deg
       << " deg > max_rotation_sigma_deg " << options.max_rotation_sigma_deg;
    out.failure = os.str();
    return out;
  }
  out.success = true;
  return out;
}

}  // namespace pl_slam
