// The steps of local mapping, one file each; run in order by LocalMapper for every keyframe.
// Internal to src/mapping.
#pragma once

#include <atomic>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/map/map.h"
#include "pl_slam/loop/loop_closer.h"
#include "pl_slam/mapping/local_mapper.h"
#include "pl_slam/optimization/bundle_adjustment.h"

namespace pl_slam {
namespace mapping {

/// Segments without a 3D position followed from keyframe to keyframe until they can be
/// triangulated: for each keyframe, per line, the keyframe and line index where its track
/// started ({kNoId, -1}: none). Only the mapping thread uses it.
using LineTracks = std::unordered_map<KeyframeId, std::vector<std::pair<KeyframeId, int>>>;

/// The last inserted keyframe's left image: landmarks made from its features take their
/// alignment patch from it (matching/patch_alignment.h). Only the mapping thread uses it.
struct PreviousImage {
  KeyframeId id = kNoId;
  cv::Mat image;
};

/// Everything a step needs.
struct Context {
  StereoCamera camera;
  MappingOptions options;
  MappingFrontEnd front_end;
  Map* map = nullptr;
  LineTracks* line_tracks = nullptr;        ///< owned by LocalMapper; null: no line triangulation
  PreviousImage* previous_image = nullptr;  ///< owned by LocalMapper; null: no patches
};

/// Two-view triangulation of a segment neither view has a stereo depth for (one nearly along
/// the image rows, as a skirting board or a door lintel seen head-on): the 3D line lies in the
/// plane through each camera centre and its image line; the newer view b's endpoints are cast
/// onto the older view a's plane. False when the planes meet at less than `min_angle_rad`
/// (too little parallax: the depth would be noise), an endpoint lands behind either camera or
/// beyond `max_depth` (m), or the result does not overlap a's segment.
bool TriangulateLine(const StereoCamera& cam, const SE3& T_w_a, const LineFeature& a,
                     const SE3& T_w_b, const LineFeature& b, double min_angle_rad, double max_depth,
                     Eigen::Vector3d* P_w, Eigen::Vector3d* Q_w);

/// Inserts the keyframe: pose refinement against the previous keyframe, observations of
/// existing landmarks (tracking's associations, previous-keyframe matches, local-map search)
/// and new landmarks from its remaining stereo features; then, with options.align_points and
/// an image, AlignPointObservations.
void InsertKeyframe(const Context& ctx, KeyframeInput* input);

/// Takes the patches of landmarks made from keyframe `kf`'s (or the previous keyframe's)
/// features and moves kf's other point observations to where their landmark's patch aligns
/// in `image` (Keyframe::point_offsets). Observations whose view warps the reference patch
/// (scale, shear or rotation) by more than 8 % are left as detected.
void AlignPointObservations(const Context& ctx, Keyframe* kf, const cv::Mat& image);

/// A part of the map copied into a bundle adjustment problem, with the ids to write it back.
struct BaWindow {
  BaProblem problem;
  std::vector<KeyframeId> pose_ids;  ///< per problem pose
  std::vector<LandmarkId> point_ids, line_ids;
  std::vector<std::pair<LandmarkId, KeyframeId>> point_obs_ids, line_obs_ids;
};

/// Caller holds the map lock. Copies keyframes `free` (optimised), every landmark they observe
/// with at least two observations, and up to `max_fixed` other keyframes observing those
/// landmarks (held fixed, the ones sharing most first); with none of those, the oldest free
/// keyframe is fixed (the gauge). False when fewer than two keyframes exist.
bool BuildBaWindowLocked(const Context& ctx, const std::vector<KeyframeId>& free, int max_fixed,
                         BaWindow* window);

/// Caller holds the map lock. Writes the solved poses and landmarks back (line extents
/// re-anchored to an observation) and removes the outlier observations.
void ApplyBaWindowLocked(const Context& ctx, const BaWindow& window, const BaSummary& summary);

/// Local bundle adjustment around keyframe `id`; outlier observations are removed. Observations
/// of `id` farther from their landmark's projection than the local-map search reaches (beyond
/// its median residual) are left out of the solve and removed too.
BaSummary LocalBundleAdjustment(const Context& ctx, KeyframeId id);

/// A global bundle adjustment: the whole map copied at one moment, solved, then merged.
struct GlobalBa {
  BaWindow window;
  std::vector<SE3, Eigen::aligned_allocator<SE3>> before;  ///< poses when copied
  BaSummary summary;
};

/// Copies every keyframe and landmark (mapping thread). False when there is nothing to adjust.
bool PrepareGlobalBundleAdjustment(const Context& ctx, GlobalBa* job);

/// Solves a prepared job without touching the map (any thread). Stops early, unsuccessful,
/// when `abort` becomes true.
void SolveGlobalBundleAdjustment(const Context& ctx, int max_iterations,
                                 const std::atomic<bool>* abort, GlobalBa* job);

/// Merges a solved job into the map (mapping thread): copied keyframes and landmarks take the
/// solution; keyframes inserted since the copy move with their spanning-tree ancestor's
/// correction, and landmarks left out (new, or seen once) with their reference keyframe's.
/// False when the solve did not succeed (the map is left alone).
bool ApplyGlobalBundleAdjustment(const Context& ctx, const GlobalBa& job);

/// Removes landmarks that were not re-observed and keyframes whose landmarks are seen by
/// enough others; returns the number of keyframes culled.
int Cull(const Context& ctx, KeyframeId id);

/// Corrects the map after a verified loop (pose graph over the essential graph, landmarks
/// moved with their reference keyframes, duplicates fused); false when it could not.
/// `newest_correction` (may be null): T_w_new * T_w_old^-1 of the newest keyframe.
bool CorrectLoop(const Context& ctx, const LoopDetection& loop, const PoseGraphOptions& options,
                 double loop_edge_weight, SE3* newest_correction = nullptr);

/// 1 / sigma of a point observation at `octave`.
inline double PointSqrtInfo(const Context& ctx, int octave) {
  return std::pow(ctx.front_end.scale_factor, -octave);
}

}  // namespace mapping
}  // namespace pl_slam
