// A part of the map copied into a BaProblem and written back after the solve: the common part
// of local bundle adjustment (a covisible window) and global bundle adjustment (every keyframe).
#include <algorithm>
#include <unordered_map>

#include "mapping_steps.h"
#include "pl_slam/optimization/line_cost.h"

namespace pl_slam {
namespace mapping {

bool BuildBaWindowLocked(const Context& ctx, const std::vector<KeyframeId>& free, int max_fixed,
                         BaWindow* window) {
  Map& map = *ctx.map;
  BaWindow& w = *window;
  w = BaWindow();
  BaProblem& problem = w.problem;
  std::unordered_map<KeyframeId, int> pose_index;
  for (KeyframeId k : free) {
    const auto kf = map.KeyframeLocked(k);
    if (!kf || pose_index.count(k)) continue;
    pose_index[k] = static_cast<int>(w.pose_ids.size());
    w.pose_ids.push_back(k);
    BaPose p;
    p.T_w_c = kf->T_w_c;
    problem.poses.push_back(p);
  }
  if (w.pose_ids.size() < 2) return false;
  const std::vector<KeyframeId> local = w.pose_ids;
  std::unordered_map<LandmarkId, int> point_index, line_index;
  std::unordered_map<KeyframeId, int> outside;  // observers outside the window, by count
  for (KeyframeId k : local) {
    const auto lk = map.KeyframeLocked(k);
    for (LandmarkId lm : lk->point_landmarks) {
      if (lm == kNoId || point_index.count(lm)) continue;
      const auto p = map.PointLocked(lm);
      // A landmark seen once constrains nothing but itself: left out (cheaper solves).
      if (!p || p->observations.size() < 2) continue;
      point_index[lm] = static_cast<int>(w.point_ids.size());
      w.point_ids.push_back(lm);
      problem.points.push_back(p->p_w);
      for (const auto& obs : p->observations)
        if (!pose_index.count(obs.first)) ++outside[obs.first];
    }
    for (LandmarkId lm : lk->line_landmarks) {
      if (lm == kNoId || line_index.count(lm)) continue;
      const auto l = map.LineLocked(lm);
      if (!l || l->observations.size() < 2) continue;
      line_index[lm] = static_cast<int>(w.line_ids.size());
      w.line_ids.push_back(lm);
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
  if (static_cast<int>(fixed.size()) > max_fixed) fixed.resize(std::max(max_fixed, 0));
  for (const auto& [k, n] : fixed) {
    const auto kf = map.KeyframeLocked(k);
    if (!kf) continue;
    pose_index[k] = static_cast<int>(w.pose_ids.size());
    w.pose_ids.push_back(k);
    BaPose p;
    p.T_w_c = kf->T_w_c;
    p.fixed = true;
    problem.poses.push_back(p);
  }
  // Gauge when no keyframe outside observes the window (start of the map, or the whole map):
  // fix the oldest.
  if (fixed.empty()) {
    const auto oldest = std::min_element(w.pose_ids.begin(), w.pose_ids.end());
    problem.poses[oldest - w.pose_ids.begin()].fixed = true;
  }
  const bool stereo = ctx.options.stereo_residuals;
  // Far points: left image only (see MappingOptions::stereo_max_depth_baselines).
  const double min_true_disparity = ctx.options.stereo_max_depth_baselines > 0.0
                                        ? ctx.camera.fx / ctx.options.stereo_max_depth_baselines
                                        : 0.0;
  for (size_t i = 0; i < w.point_ids.size(); ++i) {
    const auto p = map.PointLocked(w.point_ids[i]);
    for (const auto& [k, index] : p->observations) {
      auto it = pose_index.find(k);
      if (it == pose_index.end()) continue;
      const auto kf = map.KeyframeLocked(k);
      const PointFeature& f = kf->features.points[index];
      BaPointObservation o;
      o.pose = it->second;
      o.point = static_cast<int>(i);
      o.uv = f.uv;
      // Where the landmark's patch aligned (matching/patch_alignment.h); the disparity stays.
      if (index < static_cast<int>(kf->point_offsets.size()))
        o.uv += kf->point_offsets[index].cast<double>();
      o.stereo =
          stereo && f.has_depth && ctx.camera.TrueDisparity(f.disparity) >= min_true_disparity;
      o.u_right = o.uv.x() - f.disparity;
      o.sqrt_info = PointSqrtInfo(ctx, f.octave);
      problem.point_obs.push_back(o);
      w.point_obs_ids.emplace_back(w.point_ids[i], k);
    }
  }
  const double line_info = std::sqrt(ctx.options.line_weight);
  for (size_t i = 0; i < w.line_ids.size(); ++i) {
    const auto l = map.LineLocked(w.line_ids[i]);
    for (const auto& [k, index] : l->observations) {
      auto it = pose_index.find(k);
      if (it == pose_index.end()) continue;
      const LineFeature& f = map.KeyframeLocked(k)->features.lines[index];
      BaLineObservation o;
      o.pose = it->second;
      o.line = static_cast<int>(i);
      o.s = f.s;
      o.e = f.e;
      o.stereo = stereo && f.has_depth;
      if (o.stereo) {
        o.s_right = ctx.camera.ProjectRight(f.P_c);
        o.e_right = ctx.camera.ProjectRight(f.Q_c);
        if (o.s_right == o.e_right) o.stereo = false;
      }
      o.sqrt_info = line_info * PointSqrtInfo(ctx, f.octave);
      problem.line_obs.push_back(o);
      w.line_obs_ids.emplace_back(w.line_ids[i], k);
    }
  }
  return true;
}

void ApplyBaWindowLocked(const Context& ctx, const BaWindow& w, const BaSummary& summary) {
  Map& map = *ctx.map;
  const BaProblem& problem = w.problem;
  for (size_t i = 0; i < w.pose_ids.size(); ++i) {
    if (problem.poses[i].fixed) continue;
    if (const auto kf = map.KeyframeLocked(w.pose_ids[i])) kf->T_w_c = problem.poses[i].T_w_c;
  }
  for (size_t i = 0; i < w.point_ids.size(); ++i)
    if (const auto p = map.PointLocked(w.point_ids[i])) p->p_w = problem.points[i];
  for (size_t i = 0; i < w.line_ids.size(); ++i)
    if (const auto l = map.LineLocked(w.line_ids[i])) {
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
  for (size_t k = 0; k < w.point_obs_ids.size(); ++k)
    if (summary.point_outlier[k])
      map.RemovePointObservationLocked(w.point_obs_ids[k].first, w.point_obs_ids[k].second);
  for (size_t k = 0; k < w.line_obs_ids.size(); ++k)
    if (summary.line_outlier[k])
      map.RemoveLineObservationLocked(w.line_obs_ids[k].first, w.line_obs_ids[k].second);
  map.TouchLocked();
}

}  // namespace mapping
}  // namespace pl_slam
