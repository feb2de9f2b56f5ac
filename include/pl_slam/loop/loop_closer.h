// Loop closing and relocalisation (paper Section VI, DESIGN.md item 6): every keyframe that
// local mapping has processed gets a point + line bag-of-words vector and is queried against
// the keyframe database (inverted index); candidates are normalised by the keyframe's best
// covisible neighbour, must be consistent over consecutive keyframes, are verified
// geometrically (EstimateRelativePose), and must agree with the odometry: the correction a
// loop asks for must be drift the odometry can have accumulated over the path since the
// candidate (CheckLoopAgainstOdometry; repeated facades, or a far building seen from two
// places ~90 m apart, pass geometric verification with 30-40 inliers but ask to move the
// keyframe by about the whole path). A verified loop is handed to local mapping, which
// corrects the map between two keyframes (see mapping/loop_correction). Runs in its own thread
// fed by a bounded queue; a sequential mode runs in the caller for deterministic tests.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/loop/keyframe_database.h"
#include "pl_slam/loop/relative_pose.h"
#include "pl_slam/map/map.h"
#include "pl_slam/optimization/pose_graph.h"

namespace pl_slam {

/// Options of loop closing and relocalisation.
struct LoopClosingOptions {
  bool enabled = true;     ///< detect and close loops (needs a vocabulary)
  bool relocalize = true;  ///< relocalise in the map after tracking loss (needs a vocabulary)
  /// Folder holding orb.plvoc and lbd.plvoc. Empty: the package's default vocabulary (resolved
  /// by the runner / nodelet); relative paths are relative to the package.
  std::string vocabulary;
  int queue_size = 16;                ///< keyframes waiting for detection; more are skipped
  int thread_niceness = 10;           ///< threaded: nice steps below tracking (0-19), as in mapping
  int min_keyframe_gap = 15;          ///< candidates are at least this many keyframe ids older
  int max_candidates = 4;             ///< database results examined per keyframe
  double min_score = 0.02;            ///< combined BoW score a candidate needs at least
  double min_normalized_score = 0.6;  ///< score / best score among covisible neighbours
  int consistency = 2;                ///< consecutive keyframes whose candidate groups must agree
  int relocalize_candidates = 5;      ///< database results tried for relocalisation
  double loop_edge_weight = 1.0;      ///< information of a loop edge relative to a graph edge
  /// Odometry consistency (CheckLoopAgainstOdometry): a verified loop may move the query keyframe
  /// by at most max_drift_floor + max_drift_ratio * (keyframe path length since the candidate).
  /// Stereo visual odometry drifts ~0.1-2 % of the distance travelled (KITTI: 1-3 % for the
  /// weaker systems); 0.1 leaves a 5-100x margin, and a loop asking for more is perceptual
  /// aliasing (a repeated facade, a far building seen from two places), not drift.
  double max_drift_ratio = 0.1;
  double max_drift_floor = 0.5;  ///< correction always allowed (m): short paths, noise
  /// After each loop correction, bundle-adjust the whole map on a helper thread (local mapping
  /// merges the result between keyframes; a newer loop aborts a running one). Sequential mode
  /// runs it in place.
  bool global_ba = true;
  int global_ba_iterations = 10;  ///< its Levenberg-Marquardt iterations
  /// Keyframes after a correction (with global_ba), one more global BA of the whole map; 0 =
  /// none. By then tracking and keyframe insertion have re-observed the revisited area through
  /// the fused landmarks, which the first global BA lacked.
  int global_ba_followup = 5;
  KeyframeDatabaseOptions database;  ///< "database.*"
  RelativePoseOptions verification;  ///< "verification.*"
  PoseGraphOptions pose_graph;       ///< "pose_graph.*"
  /// Empty when valid, else "key=value must be ..." naming the first bad key.
  std::string Validate() const;
};

/// A verified loop: keyframe `query` sees the place of keyframe `candidate`.
struct LoopDetection {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  KeyframeId query = kNoId;
  KeyframeId candidate = kNoId;
  SE3 T_query_candidate;  ///< X_query = T_query_candidate * X_candidate
  int inliers = 0;
  int query_frame = -1;      ///< input frame index of the query keyframe
  int candidate_frame = -1;  ///< input frame index of the candidate keyframe
};

/// What the odometry says about a verified loop, from the map's keyframe poses.
struct LoopOdometryCheck {
  double path_length = 0.0;  ///< camera path along the keyframes from candidate to query, m
  double correction = 0.0;   ///< distance the loop moves the query keyframe, m
  double allowed = 0.0;      ///< max_drift_floor + max_drift_ratio * path_length, m
  bool plausible = false;    ///< correction <= allowed
};

/// Odometry consistency of a verified loop (the check for perceptual aliasing): the loop
/// places the query keyframe at T_w_candidate * T_query_candidate^-1; the odometry (the map)
/// at T_w_query. A correction far beyond the drift the odometry can have accumulated over the
/// path since the candidate is refused. `path_length` is the camera path from the candidate
/// to the query keyframe (KeyframePathLengthLocked). Not applied to relocalisation, which
/// has no odometry to compare with.
LoopOdometryCheck CheckLoopAgainstOdometry(const SE3& T_w_query, const SE3& T_w_candidate,
                                           const SE3& T_query_candidate, double path_length,
                                           const LoopClosingOptions& options);

/// Length of the camera path through the map's keyframes with ids from `from` to `to`
/// (either order; insertion order is time order), summing the distances of consecutive
/// keyframe centres. Culled keyframes are skipped, so it is a slight underestimate. The
/// caller holds map.Lock().
double KeyframePathLengthLocked(const Map& map, KeyframeId from, KeyframeId to);

/// Counters and timings of loop closing.
struct LoopStats {
  int keyframes_queried = 0;
  int keyframes_skipped = 0;  ///< queue full
  int candidates_verified = 0;
  int rejected_by_odometry = 0;  ///< verified, but a correction beyond plausible drift
  int loops_detected = 0;
  int loops_corrected = 0;
  int relocalizations = 0;
  int database_keyframes = 0;         ///< keyframes in the database (culled ones leave it)
  std::vector<double> query_ms;       ///< BoW + database query per keyframe
  std::vector<double> correction_ms;  ///< pose graph + landmark correction per loop
  std::vector<LoopDetection, Eigen::aligned_allocator<LoopDetection>> loops;  ///< accepted
  int thread_nice = 0;  ///< nice value of the loop-closing thread (threaded mode)
};

/// Loop detection and relocalisation over one map.
class LoopCloser {
 public:
  /// Loads the vocabulary (InputError when it cannot) and starts the thread when `threaded`.
  /// Throws ConfigError on invalid options.
  LoopCloser(const StereoCamera& camera, const LoopClosingOptions& options, Map* map,
             bool threaded);
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  /// Local mapping processed keyframe `id`: add it to the database and look for a loop.
  void OnKeyframe(KeyframeId id);
  /// Adds every keyframe of the map to the database without looking for loops (after a map
  /// was loaded). Call while nothing else uses the loop closer.
  void IndexMap();
  /// Takes the oldest verified loop waiting for correction; false when there is none.
  bool TakeDetection(LoopDetection* detection);
  /// True when a verified loop waits for correction.
  bool HasDetection() const;
  /// Records that a loop was corrected (statistics).
  void OnCorrected(double ms);
  /// Relocalisation: the pose of a frame in the map from the database and geometric
  /// verification; false when no candidate verifies. Thread-safe (tracking thread).
  bool Relocalize(const StereoFeatures& frame, SE3* T_w_c, KeyframeId* keyframe);
  /// Blocks until queued keyframes are processed.
  void Flush();
  /// Forgets every keyframe (map reset).
  void Clear();
  LoopStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl_slam
