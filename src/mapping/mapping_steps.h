// The steps of local mapping, one file each; run in order by LocalMapper for every keyframe.
// Internal to src/mapping.
#pragma once

#include <memory>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/map/map.h"
#include "pl_slam/loop/loop_closer.h"
#include "pl_slam/mapping/local_mapper.h"
#include "pl_slam/optimization/bundle_adjustment.h"

namespace pl_slam {
namespace mapping {

/// Everything a step needs.
struct Context {
  StereoCamera camera;
  MappingOptions options;
  MappingFrontEnd front_end;
  Map* map = nullptr;
};

/// Inserts the keyframe: pose refinement against the previous keyframe, observations of
/// existing landmarks (tracking's associations, previous-keyframe matches, local-map search)
/// and new landmarks from its remaining stereo features.
void InsertKeyframe(const Context& ctx, KeyframeInput* input);

/// Local bundle adjustment around keyframe `id`; outlier observations are removed.
BaSummary LocalBundleAdjustment(const Context& ctx, KeyframeId id);

/// Removes landmarks that were not re-observed and keyframes whose landmarks are seen by
/// enough others; returns the number of keyframes culled.
int Cull(const Context& ctx, KeyframeId id);

/// Corrects the map after a verified loop (pose graph over the essential graph, landmarks
/// moved with their reference keyframes, duplicates fused); false when it could not.
bool CorrectLoop(const Context& ctx, const LoopDetection& loop, const PoseGraphOptions& options,
                 double loop_edge_weight);

/// 1 / sigma of a point observation at `octave`.
inline double PointSqrtInfo(const Context& ctx, int octave) {
  return std::pow(ctx.front_end.scale_factor, -octave);
}

}  // namespace mapping
}  // namespace pl_slam
