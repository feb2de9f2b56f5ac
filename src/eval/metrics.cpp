#include "pl_slam/eval/metrics.h"

#include <algorithm>
#include <cmath>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// E = (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j).
SE3 RelativeError(const SE3& gt_i, const SE3& gt_j, const SE3& est_i, const SE3& est_j) {
  return (gt_i.inverse() * gt_j).inverse() * (est_i.inverse() * est_j);
}

void CheckSameSize(const Trajectory& est, const Trajectory& gt, const char* what) {
  if (est.size() != gt.size()) {
    throw InputError(std::string(what) + ": " + std::to_string(est.size()) + " estimate poses vs " +
                     std::to_string(gt.size()) + " ground-truth poses (expected an association)");
  }
}

}  // namespace

ErrorStats ComputeErrorStats(const std::vector<double>& errors) {
  ErrorStats s;
  if (errors.empty()) return s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  double sum_sq = 0.0;
  s.min = errors.front();
  s.max = errors.front();
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

AteResult ComputeAte(const Association& association, AlignmentMode mode) {
  CheckSameSize(association.est, association.gt, "ATE");
  AteResult r;
  r.alignment = AlignTrajectories(association, mode);
  std::vector<double> rot;
  r.times.reserve(association.size());
  r.translation_errors.reserve(association.size());
  rot.reserve(association.size());
  for (std::size_t i = 0; i < association.size(); ++i) {
    const SE3 est = r.alignment.Apply(association.est[i].T_w_c);
    const SE3& gt = association.gt[i].T_w_c;
    r.times.push_back(association.est[i].t);
    r.translation_errors.push_back((gt.translation() - est.translation()).norm());
    rot.push_back(LogSO3(gt.rotation().transpose() * est.rotation()).norm() * kRadToDeg);
  }
  r.translation = ComputeErrorStats(r.translation_errors);
  r.rotation_deg = ComputeErrorStats(rot);
  return r;
}

RpeFramesResult ComputeRpeFrames(const Trajectory& est, const Trajectory& gt, int delta) {
  CheckSameSize(est, gt, "RPE");
  if (delta < 1) throw ConfigError("rpe frame delta = " + std::to_string(delta) + ": must be >= 1");
  RpeFramesResult r;
  r.delta = delta;
  std::vector<double> trans;
  std::vector<double> rot;
  const std::size_t d = static_cast<std::size_t>(delta);
  for (std::size_t i = 0; i + d < est.size(); ++i) {
    const SE3 E = RelativeError(gt[i].T_w_c, gt[i + d].T_w_c, est[i].T_w_c, est[i + d].T_w_c);
    trans.push_back(E.translation().norm());
    rot.push_back(E.RotationAngle() * kRadToDeg);
  }
  r.translation = ComputeErrorStats(trans);
  r.rotation_deg = ComputeErrorStats(rot);
  return r;
}

double PathLength(const Trajectory& traj) {
  double len = 0.0;
  for (std::size_t i = 1; i < traj.size(); ++i) {
    len += (traj[i].T_w_c.translation() - traj[i - 1].T_w_c.translation()).norm();
  }
  return len;
}

std::vector<RpeDistanceResult> ComputeRpeDistance(const Trajectory& est, const Trajectory& gt,
                                                  const std::vector<double>& lengths) {
  CheckSameSize(est, gt, "RPE");
  std::vector<double> dist(gt.size(), 0.0);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    dist[i] = dist[i - 1] + (gt[i].T_w_c.translation() - gt[i - 1].T_w_c.translation()).norm();
  }
  std::vector<RpeDistanceResult> results;
  for (double L : lengths) {
    RpeDistanceResult r;
    r.length = L;
    if (!(std::isfinite(L) && L > 0.0) || gt.size() < 2) {
      results.push_back(r);
      continue;
    }
    // Tolerance so a segment of exactly L metres is not pushed one frame further by
    // round-off in the accumulated distance.
    const double needed = L * (1.0 - 1e-9);
    std::vector<double> trans;
    double sum_t = 0.0;
    double sum_r = 0.0;
    std::size_t j = 0;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      j = std::max(j, i + 1);
      while (j < gt.size() && dist[j] - dist[i] < needed) ++j;
      if (j >= gt.size()) break;  // later starts cannot reach L either
      const SE3 E = RelativeError(gt[i].T_w_c, gt[j].T_w_c, est[i].T_w_c, est[j].T_w_c);
      trans.push_back(E.translation().norm());
      sum_t += E.translation().norm() / L;
      sum_r += E.RotationAngle() / L;
    }
    r.segments = trans.size();
    if (r.segments > 0) {
      r.translation_pct = 100.0 * sum_t / static_cast<double>(r.segments);
      r.rotation_deg_per_m = kRadToDeg * sum_r / static_cast<double>(r.segments);
    }
    r.translation = ComputeErrorStats(trans);
    results.push_back(r);
  }
  return results;
}

CoverageResult ComputeCoverage(const std::vector<double>& frame_times_in, const Trajectory& est,
                               double max_dt) {
  CoverageResult r;
  std::vector<double> frames = frame_times_in;
  std::sort(frames.begin(), frames.end());
  r.frames = frames.size();
  if (frames.empty()) return r;
  std::vector<char> covered(frames.size(), 0);
  for (const StampedPose& p : est) {
    const auto it = std::lower_bound(frames.begin(), frames.end(), p.t);
    const std::size_t next = static_cast<std::size_t>(it - frames.begin());
    std::size_t best = frames.size();
    double best_dt = max_dt;
    if (next < frames.size() && frames[next] - p.t <= best_dt) {
      best = next;
      best_dt = frames[next] - p.t;
    }
    if (next > 0 && p.t - frames[next - 1] <= best_dt &&
        (best == frames.size() || p.t - frames[next - 1] < best_dt)) {
      best = next - 1;
    }
    if (best < frames.size()) covered[best] = 1;
  }
  for (char c : covered) r.covered += c ? 1 : 0;
  r.ratio = static_cast<double>(r.covered) / static_cast<double>(r.frames);
  return r;
}

}  // namespace eval
}  // namespace pl_slam
