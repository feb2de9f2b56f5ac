// Local bundle adjustment: the new keyframe and its best covisible keyframes are optimised
// with every landmark they observe; other keyframes observing those landmarks are held fixed.
// The window is copied under the map lock, solved without it, and written back under it.
#include "mapping_steps.h"

namespace pl_slam {
namespace mapping {

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
  const BaSummary summary = SolveBundleAdjustment(ctx.camera, ctx.options.ba, &window.problem);
  if (!summary.success) return summary;
  auto lock = map.Lock();
  ApplyBaWindowLocked(ctx, window, summary);
  return summary;
}

}  // namespace mapping
}  // namespace pl_slam
