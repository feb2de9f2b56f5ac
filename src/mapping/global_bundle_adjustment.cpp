// Global bundle adjustment after a loop correction (paper Section VI; ORB-SLAM2's scheme):
// the pose graph has moved the keyframes rigidly, so the landmarks on both sides of the loop
// are only roughly consistent; one bundle adjustment over the whole map refines them together.
// The map is copied by the mapping thread, solved on a helper thread while tracking and local
// mapping go on, and merged back by the mapping thread between two keyframes.
#include <unordered_map>
#include <unordered_set>

#include "mapping_steps.h"

namespace pl_slam {
namespace mapping {

bool PrepareGlobalBundleAdjustment(const Context& ctx, GlobalBa* job) {
  Map& map = *ctx.map;
  *job = GlobalBa();
  auto lock = map.Lock();
  std::vector<KeyframeId> all;
  all.reserve(map.KeyframesLocked().size());
  for (const auto& [id, kf] : map.KeyframesLocked()) all.push_back(id);
  if (!BuildBaWindowLocked(ctx, all, 0, &job->window)) return false;
  for (const BaPose& p : job->window.problem.poses) job->before.push_back(p.T_w_c);
  return true;
}

void SolveGlobalBundleAdjustment(const Context& ctx, int max_iterations,
                                 const std::atomic<bool>* abort, GlobalBa* job) {
  BundleAdjustmentOptions options = ctx.options.ba;
  options.max_iterations = max_iterations;
  job->summary = SolveBundleAdjustment(ctx.camera, options, &job->window.problem, abort);
}

bool ApplyGlobalBundleAdjustment(const Context& ctx, const GlobalBa& job) {
  if (!job.summary.success) return false;
  Map& map = *ctx.map;
  const BaWindow& w = job.window;
  auto lock = map.Lock();
  // Correction of every copied keyframe: T_w_new * T_w_copied^-1.
  std::unordered_map<KeyframeId, SE3> correction;
  KeyframeId newest = kNoId;
  for (size_t i = 0; i < w.pose_ids.size(); ++i) {
    correction[w.pose_ids[i]] = w.problem.poses[i].T_w_c * job.before[i].inverse();
    if (newest == kNoId || w.pose_ids[i] > newest) newest = w.pose_ids[i];
  }
  // Keyframes inserted while the solve ran: their nearest copied ancestor's correction.
  std::unordered_map<KeyframeId, SE3> later;
  for (const auto& [id, kf] : map.KeyframesLocked()) {
    if (correction.count(id)) continue;
    KeyframeId a = kf->parent;
    for (int steps = 0; a != kNoId && !correction.count(a) && steps < 10000; ++steps) {
      const auto parent = map.KeyframeLocked(a);
      a = parent ? parent->parent : kNoId;
    }
    later[id] = correction.count(a) ? correction[a] : correction[newest];
  }
  auto correction_of = [&](KeyframeId reference, const std::map<KeyframeId, int>& observations,
                           SE3* T) {
    for (KeyframeId k : {reference, observations.empty() ? kNoId : observations.begin()->first}) {
      if (const auto it = correction.find(k); it != correction.end()) {
        *T = it->second;
        return true;
      }
      if (const auto it = later.find(k); it != later.end()) {
        *T = it->second;
        return true;
      }
    }
    return false;
  };
  // Landmarks left out of the solve move rigidly with their reference keyframe.
  const std::unordered_set<LandmarkId> solved_points(w.point_ids.begin(), w.point_ids.end());
  const std::unordered_set<LandmarkId> solved_lines(w.line_ids.begin(), w.line_ids.end());
  for (const auto& [id, p] : map.PointsLocked()) {
    SE3 T;
    if (!solved_points.count(id) && correction_of(p->reference, p->observations, &T))
      p->p_w = T * p->p_w;
  }
  for (const auto& [id, l] : map.LinesLocked()) {
    SE3 T;
    if (!solved_lines.count(id) && correction_of(l->reference, l->observations, &T)) {
      l->P_w = T * l->P_w;
      l->Q_w = T * l->Q_w;
    }
  }
  for (const auto& [id, T] : later)
    if (const auto kf = map.KeyframeLocked(id)) kf->T_w_c = T * kf->T_w_c;
  // Last: it re-anchors line extents to keyframe poses, which must be final by then.
  ApplyBaWindowLocked(ctx, w, job.summary);
  return true;
}

}  // namespace mapping
}  // namespace pl_slam
