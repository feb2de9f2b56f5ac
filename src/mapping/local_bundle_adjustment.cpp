// Local bundle adjustment: the new keyframe and its best covisible keyframes are optimised
// with every landmark they observe; other keyframes observing those landmarks are held fixed.
// The new keyframe's observations far from their landmarks are taken out first.
// The window is copied under the map lock, solved without it, and written back under it.
#include <algorithm>

#include "mapping_steps.h"

namespace pl_slam {
namespace mapping {
namespace {

/// Takes out of `w` the observations of its keyframe `pose` that lie farther from their
/// landmark's projection than the local-map search reaches (search_radius, whitened by the
/// octave) beyond the median of that keyframe's observations, and returns them. Such an
/// observation is not an association the map would make now (a landmark put at a wrong depth
/// by another new keyframe, or moved since). A new keyframe that sees few landmarks, all on one
/// wall (a bare corner), is held weakly along its view: one such observation was fitted by
/// moving the keyframe 9 cm, and passed the outlier test after the solve.
std::vector<std::pair<LandmarkId, KeyframeId>> TakeFarObservations(const Context& ctx, int pose,
                                                                   BaWindow* w) {
  BaProblem& p = w->problem;
  if (pose < 0 || pose >= static_cast<int>(p.poses.size())) return {};
  const SE3 T_c_w = p.poses[pose].T_w_c.inverse();
  std::vector<double> whitened(p.point_obs.size(), -1.0), residuals;
  for (size_t k = 0; k < p.point_obs.size(); ++k) {
    const BaPointObservation& o = p.point_obs[k];
    const Eigen::Vector3d X = T_c_w * p.points[o.point];
    if (o.pose != pose || !(X.z() > 0.0)) continue;  // (behind: the solve's depth test)
    whitened[k] = o.sqrt_info * (ctx.camera.Project(X) - o.uv).norm();
    residuals.push_back(whitened[k]);
  }
  std::vector<std::pair<LandmarkId, KeyframeId>> taken;
  if (residuals.empty()) return taken;
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  const double limit = ctx.options.search_radius + residuals[residuals.size() / 2];
  size_t kept = 0;
  for (size_t k = 0; k < p.point_obs.size(); ++k) {
    if (whitened[k] > limit) {
      taken.push_back(w->point_obs_ids[k]);
      continue;
    }
    p.point_obs[kept] = p.point_obs[k];
    w->point_obs_ids[kept] = w->point_obs_ids[k];
    ++kept;
  }
  p.point_obs.resize(kept);
  w->point_obs_ids.resize(kept);
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
  const std::vector<std::pair<LandmarkId, KeyframeId>> far =
      TakeFarObservations(ctx, pose, &window);
  const BaSummary summary = SolveBundleAdjustment(ctx.camera, ctx.options.ba, &window.problem);
  if (!summary.success) return summary;
  auto lock = map.Lock();
  ApplyBaWindowLocked(ctx, window, summary);
  for (const auto& [landmark, keyframe] : far) map.RemovePointObservationLocked(landmark, keyframe);
  return summary;
}

}  // namespace mapping
}  // namespace pl_slam
