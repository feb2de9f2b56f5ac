#include "pl_slam/camera/stereo_check.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <limits>
#include <sstream>

namespace pl_slam {
namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

/// Pyramidal Lucas-Kanade from a to b, kept only where tracking b back lands within 0.5 px
/// of the start (forward-backward check). `ok[i]` is cleared for failed points.
void TrackBothWays(const cv::Mat& a, const cv::Mat& b, const std::vector<cv::Point2f>& from,
                   std::vector<cv::Point2f>* to, std::vector<char>* ok) {
  const cv::Size window(21, 21);
  const int levels = 5;
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 0.005);
  std::vector<uchar> st_f, st_b;
  std::vector<float> err;
  std::vector<cv::Point2f> back;
  cv::calcOpticalFlowPyrLK(a, b, from, *to, st_f, err, window, levels, stop);
  cv::calcOpticalFlowPyrLK(b, a, *to, back, st_b, err, window, levels, stop);
  ok->assign(from.size(), 0);
  for (size_t i = 0; i < from.size(); ++i) {
    const cv::Point2f e = back[i] - from[i];
    const cv::Point2f p = (*to)[i];
    (*ok)[i] = st_f[i] && st_b[i] && e.dot(e) < 0.25f && p.x >= 0 && p.y >= 0 && p.x < b.cols &&
               p.y < b.rows;
  }
}

/// Where a point of frame a, seen at `bearing` (normalised left coordinates) with measured
/// disparity d, appears in the left image of b and what disparity it has there, given b's
/// pose (angle-axis, translation: x_b = R x_a + t) and doffs: residuals against the observed
/// left pixel and the measured disparity in b (0 when b has no stereo match, d_b NaN).
/// Inverse-depth form: rho = (d + doffs) / (fx * baseline) stays smooth through points at
/// infinity, so doffs can move freely.
struct TransferError {
  TransferError(const StereoCamera& camera, const Eigen::Vector2d& bearing, double d,
                const Eigen::Vector2d& observed, double d_b, double weight)
      : fx(camera.fx),
        fy(camera.fy),
        cx(camera.cx),
        cy(camera.cy),
        fb(camera.fx * camera.baseline),
        x(bearing.x()),
        y(bearing.y()),
        d(d),
        u_b(observed.x()),
        v_b(observed.y()),
        d_b(d_b),
        w(weight) {}
  template <typename T>
  bool operator()(const T* pose, const T* doffs, T* r) const {
    const T ray[3] = {T(x), T(y), T(1.0)};
    T p[3];
    ceres::AngleAxisRotatePoint(pose, ray, p);
    const T rho = (T(d) + doffs[0]) / T(fb);
    for (int k = 0; k < 3; ++k) p[k] += pose[3 + k] * rho;
    if (!(p[2] > T(1e-6))) {
      r[0] = r[1] = r[2] = T(0.0);
      return true;
    }
    r[0] = T(w) * (T(fx) * p[0] / p[2] + T(cx) - T(u_b));
    r[1] = T(w) * (T(fy) * p[1] / p[2] + T(cy) - T(v_b));
    // In b the point's inverse depth is rho / p_z: its disparity fb * rho / p_z - doffs.
    r[2] = std::isfinite(d_b) ? T(w) * (T(fb) * rho / p[2] - doffs[0] - T(d_b)) : T(0.0);
    return true;
  }
  double fx, fy, cx, cy, fb, x, y, d, u_b, v_b, d_b, w;
};

}  // namespace

std::string StereoCheckOptions::Validate() const {
  std::ostringstream os;
  if (!(corners >= 50 && corners <= 20000))
    os << "corners=" << corners << " must be in [50, 20000]";
  else if (!(max_sigma > 0.0))
    os << "max_sigma=" << max_sigma << " must be > 0";
  else if (!(min_translation_ratio >= 0.0 && std::isfinite(min_translation_ratio)))
    os << "min_translation_ratio=" << min_translation_ratio << " must be >= 0";
  else if (!(min_points >= 10))
    os << "min_points=" << min_points << " must be >= 10";
  else if (!(min_disparity_spread >= 0.0 && std::isfinite(min_disparity_spread)))
    os << "min_disparity_spread=" << min_disparity_spread << " must be >= 0";
  return os.str();
}

StereoPairCheck CheckStereoPair(const StereoCamera& camera, const cv::Mat& left_a,
                                const cv::Mat& right_a, const cv::Mat& left_b,
                                const cv::Mat& right_b, const StereoCheckOptions& options) {
  StereoPairCheck out;
  auto fail = [&out](const std::string& why) {
    out.usable = false;
    out.reason = why;
    return out;
  };
  const std::string bad_options = options.Validate();
  if (!bad_options.empty()) return fail(bad_options);
  for (const cv::Mat* m : {&left_a, &right_a, &left_b, &right_b}) {
    if (m->empty() || m->type() != CV_8UC1 || m->cols != camera.width || m->rows != camera.height)
      return fail("images must be 8-bit grey and of the camera's size");
  }
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(left_a, corners, options.corners, 0.005, 7.0);
  if (static_cast<int>(corners.size()) < options.min_points) return fail("too few corners");

  // Temporal tracks (for the relative pose) and stereo matches of the same corners.
  std::vector<cv::Point2f> in_b, in_right;
  std::vector<char> ok_b, ok_right;
  TrackBothWays(left_a, left_b, corners, &in_b, &ok_b);
  TrackBothWays(left_a, right_a, corners, &in_right, &ok_right);
  std::vector<double> row_offsets;
  for (size_t i = 0; i < corners.size(); ++i) {
    if (!ok_right[i]) continue;
    const double dv = in_right[i].y - corners[i].y;
    if (std::abs(dv) < 3.0) row_offsets.push_back(dv);
    // Rectified: a stereo match stays on its row and lies left of the left point (or at
    // most a few pixels right of it, for distant points and a large offset).
    ok_right[i] = std::abs(dv) < 1.5 && corners[i].x - in_right[i].x > -0.1 * camera.width;
  }
  out.row_offset = Quantile(row_offsets, 0.5);
  // The stereo match in b of each point tracked into b (its measured disparity there).
  std::vector<cv::Point2f> in_right_b;
  std::vector<char> ok_right_b;
  TrackBothWays(left_b, right_b, in_b, &in_right_b, &ok_right_b);
  for (size_t i = 0; i < corners.size(); ++i) {
    ok_right_b[i] = ok_right_b[i] && ok_b[i] && std::abs(in_right_b[i].y - in_b[i].y) < 1.5 &&
                    in_b[i].x - in_right_b[i].x > -0.1 * camera.width;
  }

  // Points with a temporal track and a stereo match: the left point's bearing and measured
  // disparity in frame a, its position in frame b.
  std::vector<Eigen::Vector2d> bearing, in_b_px;
  std::vector<double> d, d_b;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (size_t i = 0; i < corners.size(); ++i) {
    if (!ok_b[i] || !ok_right[i]) continue;
    const double disparity = corners[i].x - in_right[i].x;
    const Eigen::Vector2d x((corners[i].x - camera.cx) / camera.fx,
                            (corners[i].y - camera.cy) / camera.fy);
    bearing.push_back(x);
    in_b_px.emplace_back(in_b[i].x, in_b[i].y);
    d.push_back(disparity);
    // NaN: no stereo match in b, only the left image's residuals.
    d_b.push_back(ok_right_b[i] ? in_b[i].x - in_right_b[i].x
                                : std::numeric_limits<double>::quiet_NaN());
    if (disparity > 1.0) {  // the PnP start uses the calibration as it is
      const double z = camera.fx * camera.baseline / disparity;
      object.emplace_back(x.x() * z, x.y() * z, z);
      image.push_back(in_b[i]);
    }
  }
  if (static_cast<int>(d.size()) < options.min_points || static_cast<int>(object.size()) < 6)
    return fail("too few points with both a stereo match and a track (" + std::to_string(d.size()) +
                ")");

  // Start: the pose of b from frame a's stereo points (PnP, RANSAC).
  const cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> pnp_inliers;
  if (!cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, 200, 1.0, 0.999,
                          pnp_inliers) ||
      static_cast<int>(pnp_inliers.size()) < options.min_points / 2)
    return fail("no pose between the two frames");
  double pose[6], doffs = 0.0;
  for (int k = 0; k < 3; ++k) {
    pose[k] = rvec.at<double>(k);
    pose[3 + k] = tvec.at<double>(k);
  }

  // Joint refinement of the pose and doffs over every point, robust to mismatches.
  ceres::Problem problem;
  const double pixel_noise = 0.5;
  for (size_t k = 0; k < d.size(); ++k) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<TransferError, 3, 6, 1>(
            new TransferError(camera, bearing[k], d[k], in_b_px[k], d_b[k], 1.0 / pixel_noise)),
        new ceres::HuberLoss(1.0), pose, &doffs);
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 50;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) return fail("the refinement failed");

  // Inliers of the final solution and the disparities they span.
  std::vector<double> used_d;
  for (size_t k = 0; k < d.size(); ++k) {
    double r[3];
    TransferError(camera, bearing[k], d[k], in_b_px[k], d_b[k], 1.0)(pose, &doffs, r);
    if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] < 4.0) used_d.push_back(d[k]);
  }
  out.points = static_cast<int>(used_d.size());
  out.disparity_lo = Quantile(used_d, 0.1);
  out.disparity_hi = Quantile(used_d, 0.9);
  if (out.points < options.min_points) return fail("too few points agree with one motion");
  if (out.disparity_hi - out.disparity_lo < options.min_disparity_spread)
    return fail("the points' depths are too alike to separate scale from offset");
  const Eigen::Vector3d t(pose[3], pose[4], pose[5]);
  out.translation = t.norm();
  out.rotation_deg = Eigen::Vector3d(pose[0], pose[1], pose[2]).norm() * 180.0 / 3.14159265358979;
  const double min_translation = options.min_translation_ratio * camera.baseline;
  if (t.norm() < min_translation)
    return fail("too little translation between the frames (only rotation tells no depth)");

  // Standard deviation of doffs from the solution's covariance (the residuals are in units
  // of the assumed pixel noise).
  ceres::Covariance::Options cov_options;
  ceres::Covariance covariance(cov_options);
  std::vector<std::pair<const double*, const double*>> blocks = {{&doffs, &doffs}};
  double variance = 0.0;
  if (!covariance.Compute(blocks, &problem) ||
      !covariance.GetCovarianceBlock(&doffs, &doffs, &variance) || !(variance >= 0.0))
    return fail("doffs not observable from this pair");
  out.doffs = doffs;
  out.sigma = std::sqrt(variance);
  if (!(out.sigma <= options.max_sigma)) {
    std::ostringstream os;
    os << "doffs too uncertain from this pair (sigma " << out.sigma << " px)";
    return fail(os.str());
  }
  out.usable = std::isfinite(out.doffs);
  if (!out.usable) out.reason = "no finite estimate";
  return out;
}

StereoCheckSummary SummariseStereoChecks(const std::vector<StereoPairCheck>& checks) {
  StereoCheckSummary s;
  std::vector<double> doffs, rows;
  for (const StereoPairCheck& c : checks) {
    if (!c.usable) continue;
    doffs.push_back(c.doffs);
    rows.push_back(c.row_offset);
  }
  s.pairs = static_cast<int>(doffs.size());
  if (doffs.empty()) return s;
  s.doffs = Quantile(doffs, 0.5);
  s.doffs_iqr = Quantile(doffs, 0.75) - Quantile(doffs, 0.25);
  s.row_offset = Quantile(rows, 0.5);
  s.doffs_error = 1.25 * (s.doffs_iqr / 1.349) / std::sqrt(std::max(1.0, s.pairs / 4.0));
  return s;
}

bool StereoOffsetDiffers(const StereoCheckSummary& summary, double calibrated) {
  return summary.pairs > 0 &&
         std::abs(summary.doffs - calibrated) > std::max(0.3, 3.0 * summary.doffs_error);
}

int StereoOffsetAnchorStride(int frames) { return std::max(1, frames / 40); }

StereoOffsetMeasurement MeasureStereoOffset(
    StereoSource* source, int max_frames,
    const std::function<void(int, int, const StereoPairCheck&)>& on_pair) {
  constexpr int kGaps[] = {2, 4, 8, 16};
  StereoOffsetMeasurement m;
  const StereoCamera& cam = source->camera();
  const int frames = static_cast<int>(std::min<size_t>(source->size(), std::max(0, max_frames)));
  const int stride = StereoOffsetAnchorStride(frames);
  std::deque<StereoFrame> window;  // the last kGaps[3] + 1 frames
  std::vector<StereoPairCheck> checks;
  StereoFrame f;
  for (int i = 0; i < frames && source->Next(&f); ++i) {
    ++m.frames;
    window.push_back(f);
    if (static_cast<int>(window.size()) > kGaps[3] + 1) window.pop_front();
    // Frame i closes the pairs whose anchor lies `gap` frames back.
    for (int gap : kGaps) {
      const int anchor = i - gap;
      if (anchor < 0 || anchor % stride != 0) continue;
      const StereoFrame& a = window[window.size() - 1 - gap];
      checks.push_back(CheckStereoPair(cam, a.left, a.right, f.left, f.right));
      ++m.tried;
      if (on_pair) on_pair(anchor, i, checks.back());
    }
  }
  m.summary = SummariseStereoChecks(checks);
  return m;
}

}  // namespace pl_slam
