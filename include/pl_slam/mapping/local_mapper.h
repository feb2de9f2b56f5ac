// Local mapping (paper Section V) in its own thread: keyframe insertion (pose refined against
// the previous keyframe, new landmarks and observations, a search of the local map for more
// matches), local bundle adjustment over the covisible keyframes, and culling of bad landmarks
// and redundant keyframes. Fed by tracking through a bounded queue of immutable keyframe
// messages; tracking never waits for it (a full queue drops the keyframe, counted).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/map/map.h"
#include "pl_slam/matching/line_matching.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/optimization/bundle_adjustment.h"
#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {

class LoopCloser;
struct LoopClosingOptions;

/// Options of local mapping and of tracking against the local map.
struct MappingOptions {
  bool enabled = true;   ///< build a map; off = visual odometry only
  bool threaded = true;  ///< local mapping in its own thread; off = in Process() (deterministic)
  int queue_size = 4;    ///< keyframes waiting for mapping; a full queue drops new ones
  /// Threaded: the mapping thread (and the global BA it starts) runs this many nice steps
  /// below the tracking thread (0-19), so a bundle adjustment uses the CPU time tracking
  /// leaves over instead of delaying frames.
  int thread_niceness = 10;
  int window = 10;  ///< keyframes optimised by local BA (the new one and its best covisible)
  int max_fixed_keyframes = 20;  ///< other keyframes observing the window's landmarks, held fixed
  bool refine_against_previous = true;  ///< refine a new keyframe's pose against the previous one
  int refine_min_inliers = 30;          ///< fewer inliers: keep the tracked pose
  double refine_max_correction = 0.3;   ///< larger refinement (m) of a keyframe pose is refused
  double search_radius = 8.0;           ///< local-map search radius, pixels at octave 0
  /// Segments without stereo depth (nearly along the image rows) followed from keyframe to
  /// keyframe are triangulated from two views when their planes meet at this angle or more
  /// (0 = off), and map as landmarks observed in the left image only. Off by default: on the
  /// low-texture family it lowers ATE (held-out median 7 -> 5 mm at 2 degrees), but on the
  /// KITTI clip it raised slam ATE from 0.50 to 0.58 m and the room's from 1.4 to 1.5 mm.
  double line_triangulation_min_angle_deg = 0.0;
  /// ... and when both endpoints are within this many baselines of both cameras.
  double line_triangulation_max_depth_baselines = 100.0;
  /// After insertion, merge landmarks mapped twice (the keyframe's landmarks matched with
  /// other local-map landmarks at the same place), so revisits do not pile up copies.
  bool fuse_duplicates = true;
  /// Trajectory output: a frame between two keyframes blends the corrections that bundle
  /// adjustment and loop closing gave them, by its time between them, instead of following
  /// only the earlier one (which leaves a step at every keyframe).
  bool interpolate_trajectory = true;
  int local_map_keyframes = 10;  ///< covisible keyframes whose landmarks form the local map
  int cull_after_keyframes = 3;  ///< a landmark still seen by < min_observations keyframes this
                                 ///< many keyframes after its creation is removed
  int min_observations = 2;      ///< see cull_after_keyframes
  bool cull_keyframes = true;    ///< remove redundant keyframes
  double redundant_ratio = 0.9;  ///< redundant: this share of its landmarks seen by enough others
  int redundant_min_observers = 3;  ///< "enough others"
  /// The newest this many keyframes are never culled. Tracking, the next keyframe's
  /// refinement and local BA link through them, and culling them as soon as later keyframes
  /// see their landmarks thins the map where it is being built: lines-only mapping on the
  /// corridor went from 1.7 to 9.2 mm ATE when every frame was a keyframe (docs/BENCHMARKS.md).
  int cull_keep_newest = 20;
  /// BA also uses the right image of stereo observations. Off, only the fixed keyframes hold
  /// the map's scale, and it drifts (room: ATE 1.4 -> 42 mm, Sim3 scale 0.980).
  bool stereo_residuals = true;
  /// Stereo observations of points farther than this many baselines use the left image only
  /// in bundle adjustment (0: no limit). Their disparity is a few pixels, so a small stereo
  /// calibration error (a tenth of a pixel of principal-point offset) is a large depth error
  /// that bundle adjustment would spread into the keyframe poses; their bearing stays exact.
  /// 40 as in ORB-SLAM2's close/far split.
  double stereo_max_depth_baselines = 40.0;
  /// Information of a line residual relative to a point's in local-map tracking, keyframe
  /// refinement and bundle adjustment (same default and reason as tracker.line_weight).
  double line_weight = 8.0;
  /// Bundle adjustment places each point observation where the landmark's patch from its
  /// reference keyframe aligns best (translation, zero-mean, matching/patch_alignment.h)
  /// rather than at the detected corner: a detector does not find the same surface point of
  /// a corner from every view. Needed with the disparity fitted on its own
  /// (mapping.ba.disparity_sigma): depths held by stereo leave the detector's view-dependent
  /// offsets to the poses (the held-out bare office, 4 -> 14 mm, without it; docs/BENCHMARKS.md,
  /// design decisions).
  bool align_points = true;
  bool track_local_map = true;  ///< tracking also matches the local map (bounded drift)
  int track_min_inliers = 20;   ///< fewer local-map inliers: keep the frame-to-frame pose
  /// The local-map pose replaces the frame-to-frame one only with at least this many inliers
  /// per frame-to-frame inlier: a map seen through few features (low texture) gives a noisier
  /// pose than visual odometry's.
  double track_min_inlier_ratio = 1.0;
  /// Larger local-map correction (m) is refused as a mismatch. Drift between frames is well
  /// below a millimetre; corrections of centimetres came from poorly constrained local-map
  /// estimates (fast turns) and made the trajectory jitter. Large map changes (loops) reach
  /// tracking by re-anchoring to the reference keyframe instead.
  double track_max_correction = 0.02;
  /// Larger local-map rotation correction (deg) is refused as a mismatch too.
  double track_max_correction_deg = 0.25;
  /// A keyframe proposed by tracking (entropy ratio, motion or frame count, not few inliers)
  /// is skipped when the frame's local-map inliers reach this share of the landmarks the
  /// map's last keyframe observes: the map already covers the view (a revisit), so the
  /// keyframe would only duplicate it. ORB-SLAM's "tracked < 90% of the reference keyframe"
  /// rule. Keeps the keyframe count proportional to the explored space. 0 never skips.
  double skip_covered_keyframes = 0.9;
  BundleAdjustmentOptions ba;  ///< "ba.*"
  MapOptions map;              ///< "map.*"
  /// Empty when valid, else "key=value must be ..." naming the first bad key.
  std::string Validate() const;
};

/// What tracking hands to local mapping for a new keyframe.
struct KeyframeInput {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  KeyframeId id = kNoId;  ///< assigned by the caller, increasing
  int frame_index = -1;
  double stamp_s = 0.0;
  SE3 T_w_c;  ///< tracked pose
  /// A keyframe already in the map and its pose as tracking held it when this one was made.
  /// When mapping has moved it since (bundle adjustment, a loop correction while this one was
  /// queued), the new keyframe moves with it. kNoId: the tracked pose is taken as it is.
  KeyframeId anchor = kNoId;
  SE3 T_w_anchor;
  StereoFeatures features;
  /// (feature index, landmark) pairs found by tracking against the local map.
  std::vector<std::pair<int, LandmarkId>> point_associations, line_associations;
  /// Left image (CV_8UC1, owned) for aligning point observations (align_points); may be
  /// empty.
  cv::Mat left_image;
};

/// Counters and timings of local mapping.
struct MappingStats {
  int keyframes_processed = 0;
  int keyframes_dropped = 0;  ///< the queue was full
  int keyframes_culled = 0;
  int queue_length = 0;
  double last_ba_ms = 0.0;
  double last_keyframe_ms = 0.0;  ///< whole processing of the last keyframe
  std::vector<double> ba_ms;      ///< every local BA, for benchmarks
  std::vector<double> keyframe_ms;
  int global_bas = 0;                ///< global bundle adjustments merged into the map
  int global_bas_discarded = 0;      ///< aborted by a newer loop or a reset, or failed
  int global_ba_followups = 0;       ///< of those started, follow-ups (loop.global_ba_followup)
  std::vector<double> global_ba_ms;  ///< solve time of each merged one
  int thread_nice = 0;               ///< nice value of the mapping thread (threaded mode)
};

/// The options of the modules local mapping reuses from tracking.
struct MappingFrontEnd {
  PointMatchingOptions point_matching;
  LineMatchingOptions line_matching;
  MotionEstimatorOptions motion;
  double scale_factor = 1.2;  ///< ORB pyramid scale step (observation sigma per octave)
};

/// Local mapping. Submit() from the tracking thread; the map is shared with readers.
class LocalMapper {
 public:
  /// Starts the mapping thread when options.threaded. Throws ConfigError on invalid options.
  LocalMapper(const StereoCamera& camera, const MappingOptions& options,
              const MappingFrontEnd& front_end, Map* map);
  /// Stops the thread (keyframes still queued are discarded).
  ~LocalMapper();
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  /// Hands over a keyframe. Threaded: queued, or dropped (returns false) when the queue is full.
  /// Sequential: processed before returning.
  bool Submit(KeyframeInput keyframe);
  /// Blocks until every queued keyframe has been processed and a running global bundle
  /// adjustment has been merged.
  void Flush();
  /// True when a keyframe submitted now would be processed at once: no keyframe queued or in
  /// progress (a global bundle adjustment on its helper thread does not count). Always true
  /// in sequential mode.
  bool Idle() const;
  /// Discards queued keyframes, aborts a running global bundle adjustment and waits for the
  /// keyframe in progress (before a reset).
  void Clear();
  /// Connects loop closing: every processed keyframe goes to `loop`, and its verified loops
  /// are corrected here, between keyframes (local mapping is the map's only writer), with
  /// `options`' pose graph, loop edge weight and global bundle adjustment. Call before the
  /// first Submit(); `loop` must outlive this mapper.
  void SetLoopCloser(LoopCloser* loop, const LoopClosingOptions& options);
  /// Incremented after every loop correction (trackers re-anchor to their reference keyframe).
  int loop_corrections() const;
  /// What the last loop correction did to the newest keyframe (T_w_new * T_w_old^-1; the
  /// identity before the first): about what it did to the camera.
  SE3 last_loop_correction() const;
  MappingStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl_slam
