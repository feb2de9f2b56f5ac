// Local bundle adjustment: the new keyframe and its best covisible keyframes are optimised
// with every landmark they observe; other keyframes observing those landmarks are held fixed.
// The window is copied under the map lock, solved without it, and written back under it.
#include <algorithm>
#include <unordered_map>

#include "mapping_steps.h"
#include "pl_slam/optimization/line_cost.h"

namespace pl_slam {
namespace mapping {

BaSummary LocalBundleAdjustment(const Context& ctx, KeyframeId id) {
  Map& map = *ctx.map;
  BaProblem problem;
  std::vector<KeyframeId> pose_ids;
  std::vector<LandmarkId> point_ids, line_ids;
  std::vector<std::pair<LandmarkId, KeyframeId>> point_obs_ids, line_obs_ids;
  {
    auto lock = map.Lock();
    const auto kf = map.KeyframeLocked(id);
    if (!kf) return BaSummary();
    std::vector<KeyframeId> local{id};
    for (const auto& [other, n] : map.CovisibleLocked(id, 1)) {
      if (static_cast<int>(local.size()) >= ctx.options.window) break;
      local.push_back(other);
    }
    if (local.size() < 2) return BaSummary();
    std::unordered_map<KeyframeId, int> pose_index;
    for (KeyframeId k : local) {
      pose_index[k] = static_cast<int>(pose_ids.size());
      pose_ids.push_back(k);
      BaPose p;
      p.T_w_c = map.KeyframeLocked(k)->T_w_c;
      problem.poses.push_back(p);
    }
    std::unordered_map<LandmarkId, int> point_index, line_index;
    std::unordered_map<KeyframeId, int> outside;  // observers outside the window, by count
    for (KeyframeId k : local) {
      const auto lk = map.KeyframeLocked(k);
      for (LandmarkId lm : lk->point_landmarks) {
        if (lm == kNoId || point_index.count(lm)) continue;
        const auto p = map.PointLocked(lm);
        // A landmark seen once constrains nothing but itself: left out (cheaper solves).
        if (!p || p->observations.size() < 2) continue;
        point_index[lm] = static_cast<int>(point_ids.size());
        point_ids.push_back(lm);
        problem.points.push_back(p->p_w);
        for (const auto& obs : p->observations)
          if (!pose_index.count(obs.first)) ++outside[obs.first];
      }
      for (LandmarkId lm : lk->line_landmarks) {
        if (lm == kNoId || line_index.count(lm)) continue;
        const auto l = map.LineLocked(lm);
        if (!l || l->observations.size() < 2) continue;
        line_index[lm] = static_cast<int>(line_ids.size());
        line_ids.push_back(lm);
        problem.line_P.push_back(l->P_w);
        problem.line_Q.push_back(l->Q_w);
        for (const auto& obs : l->observations)
          if (!pose_index.count(obs.first)) ++outside[obs.first];
      }
    }
    // Fixed keyframes: the outside observers sharing most landmarks with the window.
    std::vector<std::pair<KeyframeId, int>> fixed(outside.begin(), outside.end());
    std::sort(fixed.begin(), fixed.end(), [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second > b.second : a.first < b.first;
    });
    if (static_cast<int>(fixed.size()) > ctx.options.max_fixed_keyframes)
      fixed.resize(ctx.options.max_fixed_keyframes);
    for (const auto& [k, n] : fixed) {
      pose_index[k] = static_cast<int>(pose_ids.size());
      pose_ids.push_back(k);
      BaPose p;
      p.T_w_c = map.KeyframeLocked(k)->T_w_c;
      p.fixed = true;
      problem.poses.push_back(p);
    }
    // Gauge when no keyframe outside observes the window (start of the map): fix the oldest.
    if (fixed.empty()) {
      const auto oldest = std::min_element(pose_ids.begin(), pose_ids.end());
      problem.poses[oldest - pose_ids.begin()].fixed = true;
    }
    const bool stereo = ctx.options.stereo_residuals;
    for (size_t i = 0; i < point_ids.size(); ++i) {
      const auto p = map.PointLocked(point_ids[i]);
      for (const auto& [k, index] : p->observations) {
        auto it = pose_index.find(k);
        if (it == pose_index.end()) continue;
        const PointFeature& f = map.KeyframeLocked(k)->features.points[index];
        BaPointObservation o;
        o.pose = it->second;
        o.point = static_cast<int>(i);
        o.uv = f.uv;
        o.stereo = stereo && f.has_depth;
        o.u_right = f.uv.x() - f.disparity;
        o.sqrt_info = PointSqrtInfo(ctx, f.octave);
        problem.point_obs.push_back(o);
        point_obs_ids.emplace_back(point_ids[i], k);
      }
    }
    const double line_info = std::sqrt(ctx.options.line_weight);
    for (size_t i = 0; i < line_ids.size(); ++i) {
      const auto l = map.LineLocked(line_ids[i]);
      for (const auto& [k, index] : l->observations) {
        auto it = pose_index.find(k);
        if (it == pose_index.end()) continue;
        const LineFeature& f = map.KeyframeLocked(k)->features.lines[index];
        BaLineObservation o;
        o.pose = it->second;
        o.line = static_cast<int>(i);
        o.l = f.l;
        o.stereo = stereo && f.has_depth;
        if (o.stereo)
          o.l_right = LineThrough(ctx.camera.ProjectRight(f.P_c), ctx.camera.ProjectRight(f.Q_c));
        if (o.l_right.head<2>().norm() == 0.0) o.stereo = false;
        o.sqrt_info = line_info * PointSqrtInfo(ctx, f.octave);
        problem.line_obs.push_back(o);
        line_obs_ids.emplace_back(line_ids[i], k);
      }
    }
  }

  const BaSummary summary = SolveBundleAdjustment(ctx.camera, ctx.options.ba, &problem);
  if (!summary.success) return summary;

  auto lock = map.Lock();
  for (size_t i = 0; i < pose_ids.size(); ++i) {
    if (problem.poses[i].fixed) continue;
    if (const auto kf = map.KeyframeLocked(pose_ids[i])) kf->T_w_c = problem.poses[i].T_w_c;
  }
  for (size_t i = 0; i < point_ids.size(); ++i)
    if (const auto p = map.PointLocked(point_ids[i])) p->p_w = problem.points[i];
  for (size_t i = 0; i < line_ids.size(); ++i)
    if (const auto l = map.LineLocked(line_ids[i])) {
      l->P_w = problem.line_P[i];
      l->Q_w = problem.line_Q[i];
      // BA placed the line; its extent comes back from the creating keyframe's observation
      // (or the oldest one left), so that segments never shrink run after run.
      auto obs = l->observations.find(l->reference);
      if (obs == l->observations.end()) obs = l->observations.begin();
      if (obs == l->observations.end()) continue;
      const auto kf = map.KeyframeLocked(obs->first);
      if (!kf || obs->second < 0 || obs->second >= static_cast<int>(kf->features.lines.size()))
        continue;
      const LineFeature& f = kf->features.lines[obs->second];
      AnchorSegmentToObservation(ctx.camera, kf->T_w_c, f.s, f.e, &l->P_w, &l->Q_w);
    }
  for (size_t k = 0; k < point_obs_ids.size(); ++k)
    if (summary.point_outlier[k])
      map.RemovePointObservationLocked(point_obs_ids[k].first, point_obs_ids[k].second);
  for (size_t k = 0; k < line_obs_ids.size(); ++k)
    if (summary.line_outlier[k])
      map.RemoveLineObservationLocked(line_obs_ids[k].first, line_obs_ids[k].second);
  map.TouchLocked();
  return summary;
}

}  // namespace mapping
}  // namespace pl_slam
