// Culling: landmarks nobody re-observed and keyframes that add nothing, so the map grows with
// the explored space rather than with time.
#include <unordered_set>

#include "mapping_steps.h"

namespace pl_slam {
namespace mapping {

int Cull(const Context& ctx, KeyframeId id) {
  Map& map = *ctx.map;
  const MappingOptions& o = ctx.options;
  auto lock = map.Lock();
  const int now = map.KeyframesInsertedLocked();
  std::vector<LandmarkId> weak_points, weak_lines;
  for (const auto& [lm_id, p] : map.PointsLocked())
    if (now - p->created_at >= o.cull_after_keyframes &&
        static_cast<int>(p->observations.size()) < o.min_observations)
      weak_points.push_back(lm_id);
  for (const auto& [lm_id, l] : map.LinesLocked())
    if (now - l->created_at >= o.cull_after_keyframes &&
        static_cast<int>(l->observations.size()) < o.min_observations)
      weak_lines.push_back(lm_id);
  for (LandmarkId lm : weak_points) map.ErasePointLocked(lm);
  for (LandmarkId lm : weak_lines) map.EraseLineLocked(lm);

  if (!o.cull_keyframes) return 0;
  const auto& kfs = map.KeyframesLocked();
  if (kfs.size() < 3) return 0;
  const KeyframeId root = kfs.begin()->first;
  // Ids grow with insertion, so the newest keyframes are the last ones of the ordered map.
  KeyframeId oldest_kept = kNoId;
  int newest = o.cull_keep_newest;
  for (auto it = kfs.rbegin(); it != kfs.rend() && newest > 0; ++it, --newest)
    oldest_kept = it->first;
  int culled = 0;
  for (const auto& [k, n] : map.CovisibleLocked(id, 1)) {
    if (k == root || k == id) continue;
    if (oldest_kept != kNoId && k >= oldest_kept) continue;
    const auto kf = map.KeyframeLocked(k);
    if (!kf) continue;
    int total = 0, redundant = 0;
    for (LandmarkId lm : kf->point_landmarks) {
      const auto p = map.PointLocked(lm);
      if (!p) continue;
      ++total;
      if (static_cast<int>(p->observations.size()) - 1 >= o.redundant_min_observers) ++redundant;
    }
    for (LandmarkId lm : kf->line_landmarks) {
      const auto l = map.LineLocked(lm);
      if (!l) continue;
      ++total;
      if (static_cast<int>(l->observations.size()) - 1 >= o.redundant_min_observers) ++redundant;
    }
    if (total > 0 && redundant >= o.redundant_ratio * total) {
      map.EraseKeyframeLocked(k);
      ++culled;
    }
  }
  return culled;
}

}  // namespace mapping
}  // namespace pl_slam
