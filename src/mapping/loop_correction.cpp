// Loop correction, run by local mapping between two keyframes (no other writer then): pose-graph
// optimisation over the essential graph plus the new loop edge, landmarks moved with their
// reference keyframes, duplicated landmarks on both sides of the loop fused.
#include <cmath>
#include <unordered_map>

#include "mapping_steps.h"
#include "pl_slam/mapping/local_map_matching.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace mapping {
namespace {

/// Fuses the candidate side's landmarks into the query keyframe and its neighbours.
void FuseAcrossLoop(const Context& ctx, KeyframeId query, KeyframeId candidate) {
  Map& map = *ctx.map;
  const LocalMap local = map.GetLocalMap(candidate, ctx.options.local_map_keyframes);
  std::vector<std::shared_ptr<Keyframe>> targets;
  {
    auto lock = map.Lock();
    if (const auto q = map.KeyframeLocked(query)) targets.push_back(q);
    for (const auto& [k, n] : map.CovisibleLocked(query, 1)) {
      if (static_cast<int>(targets.size()) > ctx.options.local_map_keyframes) break;
      targets.push_back(map.KeyframeLocked(k));
    }
  }
  for (const auto& kf : targets) {
    LocalMapMatches matches;
    {
      // Only the mapping thread changes keyframes' landmark vectors (this thread).
      matches = MatchLocalMap(ctx.camera, local, kf->T_w_c.inverse(), kf->features, LocalMapMasks(),
                              ctx.front_end, ctx.options.search_radius);
    }
    auto lock = map.Lock();
    for (const auto& [i, j] : matches.points) {
      const LandmarkId into = local.point_ids[i];
      const LandmarkId own = kf->point_landmarks[j];
      if (own == into) continue;
      if (own == kNoId)
        map.AddPointObservationLocked(into, kf->id, j);
      else
        map.FusePointLocked(own, into);
    }
    for (const auto& [i, j] : matches.lines) {
      const LandmarkId into = local.line_ids[i];
      const LandmarkId own = kf->line_landmarks[j];
      if (own == into) continue;
      if (own == kNoId)
        map.AddLineObservationLocked(into, kf->id, j);
      else
        map.FuseLineLocked(own, into);
    }
  }
}

}  // namespace

bool CorrectLoop(const Context& ctx, const LoopDetection& loop, const PoseGraphOptions& options,
                 double loop_edge_weight, SE3* newest_correction) {
  Map& map = *ctx.map;
  std::vector<KeyframeId> ids;
  std::unordered_map<KeyframeId, int> index;
  std::vector<SE3, Eigen::aligned_allocator<SE3>> poses, before;
  std::vector<PoseGraphEdge, Eigen::aligned_allocator<PoseGraphEdge>> edges;
  std::vector<char> fixed;
  {
    auto lock = map.Lock();
    if (!map.KeyframeLocked(loop.query) || !map.KeyframeLocked(loop.candidate)) return false;
    for (const auto& [id, kf] : map.KeyframesLocked()) {
      index[id] = static_cast<int>(ids.size());
      ids.push_back(id);
      poses.push_back(kf->T_w_c);
    }
    before = poses;
    auto add_edge = [&](KeyframeId a, KeyframeId b, double weight, const SE3* measured) {
      auto ia = index.find(a), ib = index.find(b);
      if (ia == index.end() || ib == index.end()) return;
      PoseGraphEdge e;
      e.i = ia->second;
      e.j = ib->second;
      e.T_i_j = measured ? *measured : poses[e.i].inverse() * poses[e.j];
      e.weight = weight;
      edges.push_back(e);
    };
    // Essential graph: spanning tree, strong covisibility, earlier loops.
    for (const auto& [id, kf] : map.KeyframesLocked()) {
      if (kf->parent != kNoId) add_edge(kf->parent, id, 1.0, nullptr);
      for (const auto& [other, n] : map.CovisibleLocked(id, ctx.options.map.essential_min_shared))
        if (other < id && other != kf->parent) add_edge(other, id, 1.0, nullptr);
      for (KeyframeId other : kf->loop_edges)
        if (other < id) add_edge(other, id, 1.0, nullptr);
    }
    const SE3 T_candidate_query = loop.T_query_candidate.inverse();
    add_edge(loop.candidate, loop.query, loop_edge_weight, &T_candidate_query);
    edges.back().is_loop = true;
    fixed.assign(ids.size(), 0);
    fixed[index[loop.candidate]] = 1;
    fixed[0] = 1;  // the map's origin
  }
  const PoseGraphSummary summary = OptimizePoseGraph(edges, fixed, options, &poses);
  if (!summary.success) {
    PL_LOG_WARN("loop correction failed: " << summary.message);
    return false;
  }
  {
    auto lock = map.Lock();
    std::unordered_map<KeyframeId, SE3> correction;  // T_w_new * T_w_old^-1 per keyframe
    for (size_t k = 0; k < ids.size(); ++k) {
      const auto kf = map.KeyframeLocked(ids[k]);
      if (!kf) continue;
      kf->T_w_c = poses[k];
      correction[ids[k]] = poses[k] * before[k].inverse();
    }
    auto correction_of = [&](KeyframeId reference, const std::map<KeyframeId, int>& observations,
                             SE3* T) {
      auto it = correction.find(reference);
      if (it == correction.end() && !observations.empty())
        it = correction.find(observations.begin()->first);
      if (it == correction.end()) return false;
      *T = it->second;
      return true;
    };
    for (const auto& [id, p] : map.PointsLocked()) {
      SE3 T;
      if (correction_of(p->reference, p->observations, &T)) p->p_w = T * p->p_w;
    }
    for (const auto& [id, l] : map.LinesLocked()) {
      SE3 T;
      if (correction_of(l->reference, l->observations, &T)) {
        l->P_w = T * l->P_w;
        l->Q_w = T * l->Q_w;
      }
    }
    // The newest keyframe's correction: what the camera moves by (map -> odom takes it).
    const SE3& newest = correction[ids.back()];
    if (newest_correction) *newest_correction = newest;
    PL_LOG_INFO("loop corrected: keyframe " << loop.query << " joined keyframe " << loop.candidate
                                            << "; the newest keyframe moved "
                                            << newest.translation().norm() * 1000.0 << " mm, "
                                            << newest.RotationAngle() * 180.0 / M_PI << " deg");
    map.KeyframeLocked(loop.query)->loop_edges.insert(loop.candidate);
    map.KeyframeLocked(loop.candidate)->loop_edges.insert(loop.query);
    map.TouchLocked();
  }
  FuseAcrossLoop(ctx, loop.query, loop.candidate);
  return true;
}

}  // namespace mapping
}  // namespace pl_slam
