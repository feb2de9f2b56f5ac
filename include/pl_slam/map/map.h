// The SLAM map (paper Section III): keyframes, point and line landmarks, and the graphs over
// the keyframes (covisibility, essential graph, spanning tree).
//
// Ownership and locking (house style item 6):
//  - The Map owns every keyframe and landmark (shared_ptr in id-keyed containers). Keyframes
//    refer to landmarks and landmarks to keyframes by id only, so there are no reference
//    cycles; erasing an object from the map frees it (readers holding a Snapshot keep copies,
//    not pointers).
//  - One mutex guards the whole map. It is a leaf lock: code holding it takes no other lock
//    and calls nothing that might. The methods below take it themselves, except those named
//    *Locked, which expect the caller to hold the lock returned by Lock() (the local mapper
//    uses them to apply one keyframe's changes atomically).
//  - Only the mapping back end (local mapper, later loop closing) changes the map; tracking and
//    the ROS layer read it through LocalMap() and Snapshot(), each one consistent copy.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <opencv2/core.hpp>

#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

using KeyframeId = int64_t;
using LandmarkId = int64_t;
constexpr int64_t kNoId = -1;

/// A keyframe: the features of one stereo frame and its pose.
struct Keyframe {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  KeyframeId id = kNoId;
  int frame_index = -1;                     ///< index of the frame in the input stream
  double stamp_s = 0.0;                     ///< time stamp, seconds
  SE3 T_w_c;                                ///< pose of the left camera in the map
  StereoFeatures features;                  ///< immutable after insertion
  std::vector<LandmarkId> point_landmarks;  ///< per point feature; kNoId when none
  std::vector<LandmarkId> line_landmarks;   ///< per line feature; kNoId when none
  /// Per point feature: where aligning its landmark's reference patch moved the observation
  /// (pixels; bundle adjustment uses uv + offset). Empty or zero: not aligned. Written by
  /// local mapping under the map lock; not stored in map files.
  std::vector<Eigen::Vector2f> point_offsets;
  KeyframeId parent = kNoId;        ///< spanning-tree parent (kNoId for the root)
  std::set<KeyframeId> loop_edges;  ///< keyframes joined by an accepted loop
};

/// A 3D point landmark.
struct PointLandmark {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  LandmarkId id = kNoId;
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  ///< position in the map
  cv::Mat descriptor;                             ///< representative ORB descriptor (1 x 32)
  int octave = 0;                                 ///< pyramid level of the first observation
  std::map<KeyframeId, int> observations;         ///< keyframe -> point feature index
  KeyframeId reference = kNoId;                   ///< keyframe that created it
  int created_at = 0;  ///< number of keyframes in the map when it was created
  /// Intensities around its observation in `reference` (matching/patch_alignment.h); empty
  /// when none was taken. Not stored in map files.
  std::vector<uint8_t> patch;
};

/// A 3D line-segment landmark (endpoints P, Q).
struct LineLandmark {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  LandmarkId id = kNoId;
  Eigen::Vector3d P_w = Eigen::Vector3d::Zero();  ///< start point in the map
  Eigen::Vector3d Q_w = Eigen::Vector3d::Zero();  ///< end point in the map
  cv::Mat descriptor;                             ///< representative LBD descriptor (1 x 32)
  int octave = 0;                                 ///< pyramid level of the first observation
  std::map<KeyframeId, int> observations;         ///< keyframe -> line feature index
  KeyframeId reference = kNoId;
  int created_at = 0;
  /// Unit direction (Q - P) / |Q - P| (zero for a degenerate segment).
  Eigen::Vector3d Direction() const;
};

/// Landmarks near a keyframe, copied for tracking against the local map. Row i of a
/// descriptor matrix belongs to element i.
struct LocalMap {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  KeyframeId reference = kNoId;  ///< keyframe whose neighbourhood this is
  uint64_t version = 0;          ///< Map::version() when copied
  std::vector<LandmarkId> point_ids;
  PointFeatures points;  ///< p_c holds the WORLD position, octave the landmark's octave
  cv::Mat point_descriptors;
  std::vector<LandmarkId> line_ids;
  LineFeatures lines;  ///< P_c, Q_c hold WORLD endpoints
  cv::Mat line_descriptors;
  /// Landmarks (points + lines) the reference keyframe observes that at least 3 keyframes
  /// see: the well-established part of its view.
  int reference_landmarks = 0;
};

/// A consistent copy of the map for display and output (markers, path, map files).
struct MapSnapshot {
  struct KeyframePose {
    EIGEN_MAKE_ALIGNED_OPERATOR_NEW
    KeyframeId id = kNoId;
    int frame_index = -1;
    double stamp_s = 0.0;
    SE3 T_w_c;
  };
  std::vector<KeyframePose, Eigen::aligned_allocator<KeyframePose>> keyframes;     ///< by id
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points;  ///< p_w
  /// Line landmarks as (P_w, Q_w) pairs.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>,
              Eigen::aligned_allocator<std::pair<Eigen::Vector3d, Eigen::Vector3d>>>
      lines;
  std::vector<std::pair<KeyframeId, KeyframeId>> covisibility_edges;  ///< i < j
  std::vector<std::pair<KeyframeId, KeyframeId>> essential_edges;     ///< i < j
  std::vector<std::pair<KeyframeId, KeyframeId>> loop_edges;          ///< i < j
  uint64_t version = 0;
};

/// Map sizes, for status output and the memory benchmark.
struct MapCounts {
  size_t keyframes = 0, points = 0, lines = 0;
  size_t culled_keyframes = 0, culled_points = 0, culled_lines = 0;
};

/// Everything a Map holds except its options and version: what a map file stores
/// (map/map_io.h). Map::ExportLocked() fills it, Map::ReplaceLocked() installs it.
struct MapContents {
  std::map<KeyframeId, std::shared_ptr<Keyframe>> keyframes;
  std::unordered_map<LandmarkId, std::shared_ptr<PointLandmark>> points;
  std::unordered_map<LandmarkId, std::shared_ptr<LineLandmark>> lines;
  /// Culled keyframe -> (parent at culling time, T_parent_kf), as in the Map.
  std::unordered_map<KeyframeId, std::pair<KeyframeId, SE3>> culled;
  LandmarkId next_landmark_id = 0;  ///< id the next point or line landmark gets
  int keyframes_inserted = 0;       ///< keyframes inserted so far (ever)
  size_t culled_points = 0;         ///< point landmarks erased so far (statistics)
  size_t culled_lines = 0;          ///< line landmarks erased so far (statistics)
};

/// Graph thresholds of the map.
struct MapOptions {
  int covisibility_min_shared = 20;  ///< covisibility edge: at least this many shared landmarks
  int essential_min_shared = 100;    ///< essential graph edge: more than this many shared
  /// Empty when valid, else "key=value must be ..." naming the first bad key.
  std::string Validate() const;
};

/// The map. Thread-safe as described at the top of this file.
class Map {
 public:
  explicit Map(const MapOptions& options = MapOptions());
  Map(const Map&) = delete;
  Map& operator=(const Map&) = delete;

  const MapOptions& options() const { return options_; }

  /// The map lock, for the *Locked methods.
  std::unique_lock<std::mutex> Lock() const { return std::unique_lock<std::mutex>(mutex_); }

  /// Incremented by every change; readers use it to refresh cached copies.
  uint64_t version() const;
  MapCounts counts() const;
  /// Removes everything (ids keep increasing so that stale ids never alias new objects).
  void Clear();

  /// Landmarks observed by `reference` and by its `max_neighbours` best covisible keyframes,
  /// with their descriptors; empty when the keyframe is unknown.
  LocalMap GetLocalMap(KeyframeId reference, int max_neighbours) const;
  /// A consistent copy for display and output.
  MapSnapshot Snapshot() const;
  /// Pose of a keyframe; false when it is not (or no longer) in the map and was not culled.
  /// Culled keyframes resolve through their spanning-tree parent at the time of culling.
  bool KeyframePose(KeyframeId id, SE3* T_w_c) const;
  /// The newest keyframe, kNoId when the map is empty.
  KeyframeId LastKeyframe() const;

  // --- caller holds Lock() -----------------------------------------------------------------
  /// Adds a keyframe (its id already set, landmarks vectors sized to its features).
  void AddKeyframeLocked(std::shared_ptr<Keyframe> kf);
  /// Creates a point landmark observed by `kf` at feature `index`; returns its id.
  LandmarkId AddPointLocked(const Eigen::Vector3d& p_w, KeyframeId kf, int index);
  /// Creates a line landmark observed by `kf` at line feature `index`; returns its id.
  LandmarkId AddLineLocked(const Eigen::Vector3d& P_w, const Eigen::Vector3d& Q_w, KeyframeId kf,
                           int index);
  /// Adds an observation; false when either object is gone or the feature already has one.
  bool AddPointObservationLocked(LandmarkId lm, KeyframeId kf, int index);
  bool AddLineObservationLocked(LandmarkId lm, KeyframeId kf, int index);
  /// Removes an observation; a landmark left without observations is erased (freed).
  void RemovePointObservationLocked(LandmarkId lm, KeyframeId kf);
  void RemoveLineObservationLocked(LandmarkId lm, KeyframeId kf);
  /// Erases a landmark and its observations.
  void ErasePointLocked(LandmarkId lm);
  void EraseLineLocked(LandmarkId lm);
  /// Merges landmark `from` into `into` (a duplicate found after a loop closure): every
  /// observation of `from` in a keyframe that does not observe `into` yet moves over; `from`
  /// is erased. False when either is missing or they are the same.
  bool FusePointLocked(LandmarkId from, LandmarkId into);
  bool FuseLineLocked(LandmarkId from, LandmarkId into);
  /// Erases a keyframe: its observations go, orphaned landmarks are freed, its children are
  /// re-parented to its parent, and its pose stays resolvable through KeyframePose().
  void EraseKeyframeLocked(KeyframeId id);
  /// Covisible keyframes of `id` (shared landmark counts), best first, at least `min_shared`.
  std::vector<std::pair<KeyframeId, int>> CovisibleLocked(KeyframeId id, int min_shared) const;
  void TouchLocked() { ++version_; }

  std::shared_ptr<Keyframe> KeyframeLocked(KeyframeId id) const;
  std::shared_ptr<PointLandmark> PointLocked(LandmarkId id) const;
  std::shared_ptr<LineLandmark> LineLocked(LandmarkId id) const;
  const std::map<KeyframeId, std::shared_ptr<Keyframe>>& KeyframesLocked() const {
    return keyframes_;
  }
  const std::unordered_map<LandmarkId, std::shared_ptr<PointLandmark>>& PointsLocked() const {
    return points_;
  }
  const std::unordered_map<LandmarkId, std::shared_ptr<LineLandmark>>& LinesLocked() const {
    return lines_;
  }
  /// Number of keyframes inserted so far (ever), the clock of landmark culling.
  int KeyframesInsertedLocked() const { return keyframes_inserted_; }
  /// A copy of everything (for map files) that later changes to the map do not affect:
  /// keyframes and landmarks are copied; keyframe feature matrices are shared, being immutable.
  MapContents ExportLocked() const;
  /// Replaces everything with `contents` in one step and bumps version(); the caller has
  /// checked its consistency (LoadMap does). The landmark id counter never goes down, so ids
  /// held from before the replacement do not alias new landmarks.
  void ReplaceLocked(MapContents&& contents);

 private:
  bool KeyframePoseLocked(KeyframeId id, SE3* T_w_c) const;

  MapOptions options_;
  mutable std::mutex mutex_;
  uint64_t version_ = 0;
  LandmarkId next_landmark_id_ = 0;
  int keyframes_inserted_ = 0;
  std::map<KeyframeId, std::shared_ptr<Keyframe>> keyframes_;
  std::unordered_map<LandmarkId, std::shared_ptr<PointLandmark>> points_;
  std::unordered_map<LandmarkId, std::shared_ptr<LineLandmark>> lines_;
  /// Culled keyframe -> (parent at culling time, T_parent_kf): trajectories keep resolving.
  std::unordered_map<KeyframeId, std::pair<KeyframeId, SE3>> culled_;
  size_t culled_points_ = 0, culled_lines_ = 0;
};

}  // namespace pl_slam
