// Local bundle adjustment: the new keyframe and its best covisible keyframes are optimised
// with every landmark they observe; other keyframes observing those landmarks are held fixed.
// The new keyframe's observations far from their landmarks are taken out first.
// The window is copied under the map lock, solved without it, and written back under it.
#include <algorithm>
#include <cmath>

#include "mapping_steps.h"
#include "pl_slam/optimization/line_cost.h"

namespace pl_slam {
namespace mapping {
namespace {

/// Observations taken out of a window before its solve, to be removed from the map after it.
struct FarObservations {
  std::vector<std::pair<LandmarkId, KeyframeId>> points, lines;
};

/// The median of `residuals`; -1 when it is empty.
double Median(std::vector<double> residuals) {
  if (residuals.empty()) return -1.0;
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  return residuals[residuals.size() / 2];
}

/// Keeps the entries of `obs` (and their ids) whose `whitened` residual is at most `limit`;
/// appends the ids of the others to `taken`.
template <typename Observation>
void KeepWithin(const std::vector<double>& whitened, double limit,
                std::vector<Observation, Eigen::aligned_allocator<Observation>>* obs,
                std::vector<std::pair<LandmarkId, KeyframeId>>* ids,
                std::vector<std::pair<LandmarkId, KeyframeId>>* taken) {
  size_t kept = 0;
  for (size_t k = 0; k < obs->size(); ++k) {
    if (whitened[k] > limit) {
      taken->push_back((*ids)[k]);
      continue;
    }
    (*obs)[kept] = (*obs)[k];
    (*ids)[kept] = (*ids)[k];
    ++kept;
  }
  obs->resize(kept);
  ids->resize(kept);
}

/// Takes out of `w` the observations of its keyframe `pose` that lie farther from their
/// landmark's projection than the map's own matching reaches, beyond the median of that
/// keyframe's observations of the same kind (whitened by the octave), and returns them. Points:
/// the local-map search radius (search_radius). Segments: the guided line matcher's distance
/// (line_matching.f2f_max_line_distance), of the observed endpoints to the landmark's projected
/// line or of the projected endpoints to the observed line, whichever is nearer (a long
/// landmark's endpoints may project far outside the image, where a fraction of a degree is many
/// pixels; a landmark seen nearly end-on projects too short to have a direction). Such an
/// observation is not an association the map would make now (a landmark put at a wrong depth by
/// another new keyframe, or moved since). A new keyframe that sees few landmarks, all on one wall
/// (a bare corner, a whiteboard close up), is held weakly along its view: one such point
/// observation was fitted by moving the keyframe 9 cm, and passed the outlier test after the solve;
/// one segment 440 px from its landmark's projection moved one 0.8 m and 31 deg, after which every
/// other observation of it was an outlier.
FarObservations TakeFarObservations(const Context& ctx, int pose, BaWindow* w) {
  BaProblem& p = w->problem;
  FarObservations taken;
  if (pose < 0 || pose >= static_cast<int>(p.poses.size())) return taken;
  const SE3 T_c_w = p.poses[pose].T_w_c.inverse();
  std::vector<double> whitened(p.point_obs.size(), -1.0), residuals;
  for (size_t k = 0; k < p.point_obs.size(); ++k) {
    const BaPointObservation& o = p.point_obs[k];
    const Eigen::Vector3d X = T_c_w * p.points[o.point];
    if (o.pose != pose || !(X.z() > 0.0)) continue;  // (behind: the solve's depth test)
    whitened[k] = o.sqrt_info * (ctx.camera.Project(X) - o.uv).norm();
    residuals.push_back(whitened[k]);
  }
  if (!residuals.empty())
    KeepWithin(whitened, ctx.options.search_radius + Median(residuals), &p.point_obs,
               &w->point_obs_ids, &taken.points);
  // Segments: BaLineObservation::sqrt_info carries line_weight on top of the octave's.
  const double line_info = std::sqrt(ctx.options.line_weight);
  whitened.assign(p.line_obs.size(), -1.0);
  residuals.clear();
  for (size_t k = 0; k < p.line_obs.size(); ++k) {
    const BaLineObservation& o = p.line_obs[k];
    if (o.pose != pose) continue;
    const Eigen::Vector3d P = T_c_w * p.line_P[o.line], Q = T_c_w * p.line_Q[o.line];
    if (!(P.z() > 0.0) || !(Q.z() > 0.0)) continue;
    const Eigen::Vector2d a = ctx.camera.Project(P), b = ctx.camera.Project(Q);
    const Eigen::Vector3d m = LineThrough(a, b), l = LineThrough(o.s, o.e);
    if (m.head<2>().squaredNorm() == 0.0 || l.head<2>().squaredNorm() == 0.0) continue;
    const auto farther = [](const Eigen::Vector3d& line, const Eigen::Vector2d& x,
                            const Eigen::Vector2d& y) {
      return std::max(std::abs(line.dot(x.homogeneous())), std::abs(line.dot(y.homogeneous())));
    };
    whitened[k] = o.sqrt_info / line_info * std::min(farther(m, o.s, o.e), farther(l, a, b));
    residuals.push_back(whitened[k]);
  }
  if (!residuals.empty())
    KeepWithin(whitened, ctx.front_end.line_matching.f2f_max_line_distance + Median(residuals),
               &p.line_obs, &w->line_obs_ids, &taken.lines);
  return taken;
}

}  // namespace

BaSummary LocalBundleAdjustment(const Context& ctx, KeyframeId id) {
  Map& map = *ctx.map;
  BaWindow window;
  {
    auto lock = map.Lock();
    if (!map.KeyframeLocked(id)) return BaSummary();
    std::vector<KeyframeId> local{id};
    for (const auto& [other, n] : map.CovisibleLocked(id, 1)) {
      if (static_cast<int>(local.size()) >= ctx.options.window) break;
      local.push_back(other);
    }
    if (!BuildBaWindowLocked(ctx, local, ctx.options.max_fixed_keyframes, &window))
      return BaSummary();
  }
  const int pose = static_cast<int>(std::find(window.pose_ids.begin(), window.pose_ids.end(), id) -
                                    window.pose_ids.begin());
  const FarObservations far = TakeFarObservations(ctx, pose, &window);
  const BaSummary summary = SolveBundleAdjustment(ctx.camera, ctx.options.ba, &window.problem);
  if (!summary.success) return summary;
  auto lock = map.Lock();
  ApplyBaWindowLocked(ctx, window, summary);
  for (const auto& [landmark, keyframe] : far.points)
    map.RemovePointObservationLocked(landmark, keyframe);
  for (const auto& [landmark, keyframe] : far.lines)
    map.RemoveLineObservationLocked(landmark, keyframe);
  return summary;
}

}  // namespace mapping
}  // namespace pl_slam
