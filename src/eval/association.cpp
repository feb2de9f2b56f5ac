#include "pl_slam/eval/association.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

void AssociationOptions::Validate() const {
  if (!(std::isfinite(max_dt) && max_dt > 0.0)) {
    throw ConfigError("max_dt = " + std::to_string(max_dt) + " s: must be finite and > 0");
  }
}

SE3 InterpolatePose(const SE3& a, const SE3& b, double alpha) {
  const double s = std::min(1.0, std::max(0.0, alpha));
  const Eigen::Quaterniond q = a.so3().slerp(s, b.so3());
  const Eigen::Vector3d t = (1.0 - s) * a.translation() + s * b.translation();
  return SE3(q, t);
}

Trajectory SortedByTime(const Trajectory& traj) {
  Trajectory sorted = traj;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const StampedPose& x, const StampedPose& y) { return x.t < y.t; });
  return sorted;
}

Association AssociateTrajectories(const Trajectory& est_in, const Trajectory& gt_in,
                                  const AssociationOptions& options) {
  options.Validate();
  Association out;
  if (est_in.empty()) return out;
  if (gt_in.empty()) {
    out.unmatched = est_in.size();
    return out;
  }
  const Trajectory est = SortedByTime(est_in);
  const Trajectory gt = SortedByTime(gt_in);
  std::vector<double> gt_times(gt.size());
  for (std::size_t k = 0; k < gt.size(); ++k) gt_times[k] = gt[k].t;

  for (std::size_t i = 0; i < est.size(); ++i) {
    const double t = est[i].t;
    // First gt sample at or after t; its predecessor is the sample before t.
    const auto it = std::lower_bound(gt_times.begin(), gt_times.end(), t);
    const std::size_t next = static_cast<std::size_t>(it - gt_times.begin());
    const bool has_next = next < gt.size() && gt_times[next] - t <= options.max_dt;
    const bool has_prev = next > 0 && t - gt_times[next - 1] <= options.max_dt;
    StampedPose g;
    g.t = t;
    if (has_next && gt_times[next] == t) {
      g.T_w_c = gt[next].T_w_c;
    } else if (has_prev && has_next && options.interpolate) {
      const double t0 = gt_times[next - 1];
      const double t1 = gt_times[next];
      const double alpha = t1 > t0 ? (t - t0) / (t1 - t0) : 0.0;
      g.T_w_c = InterpolatePose(gt[next - 1].T_w_c, gt[next].T_w_c, alpha);
      ++out.interpolated;
    } else if (has_prev || has_next) {
      const bool take_next = has_next && (!has_prev || gt_times[next] - t < t - gt_times[next - 1]);
      g.T_w_c = take_next ? gt[next].T_w_c : gt[next - 1].T_w_c;
    } else {
      ++out.unmatched;
      continue;
    }
    out.est.push_back(est[i]);
    out.gt.push_back(g);
    out.est_indices.push_back(i);
  }
  return out;
}

}  // namespace eval
}  // namespace pl_slam
