// The core pipeline facade: one call per stereo frame. The offline runner, the nodelet, the
// benchmarks and the tests all drive the system through this class.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/stereo_frame.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/loop/loop_closer.h"
#include "pl_slam/map/map.h"
#include "pl_slam/mapping/local_mapper.h"
#include "pl_slam/tracking/stereo_tracker.h"
#include "pl_slam/util/option_table.h"

namespace pl_slam {

/// Tracking state after a frame.
enum class TrackingState { kNotInitialized = 0, kTracking = 1, kLost = 2 };

/// Human-readable name of a tracking state ("NOT_INITIALIZED", "TRACKING", "LOST").
const char* TrackingStateName(TrackingState state);

/// Options of the whole system (one nested struct per module).
struct SystemOptions {
  TrackerOptions tracker;   ///< "tracker.*": front end (features, matching, motion, keyframes)
  MappingOptions mapping;   ///< "mapping.*": map, local mapping, local BA, local-map tracking
  LoopClosingOptions loop;  ///< "loop.*": loop closing and relocalisation

  /// Empty when valid, else "key=value: allowed range" naming the first bad key.
  std::string Validate() const;
};

/// The table of every option key of `options` ("tracker.points.max_points", ...), for YAML
/// files, ROS parameters and command-line overrides.
OptionTable MakeOptionTable(SystemOptions* options);

/// What the system reports for one frame.
struct FrameResult {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  TrackingState state = TrackingState::kNotInitialized;
  SE3 T_w_c;                                   ///< current left-camera pose (last good when lost)
  Matrix6d covariance = Matrix6d::Identity();  ///< of the frame-to-frame increment [rho; phi]
  /// This frame's motion as tracking measured it (frame to frame and against the local map,
  /// or the motion model's while lost; identity on a relocalisation): T_odom_c's step.
  SE3 T_prev_cur;
  /// REP-105 odometry: the camera pose chained from the tracked motion only, continuous
  /// across bundle adjustment, loop corrections and relocalisation (map -> odom =
  /// T_w_c * T_odom_c^-1 takes those). The odom frame is the SLAM world at the start.
  SE3 T_odom_c;
  /// Covariance of T_odom_c over [position; rotation about the odom axes], odom frame:
  /// grows with the tracked motion, reset to the last increment's after a loop correction
  /// or a relocalisation (see system/odometry.h).
  Matrix6d odom_covariance = Matrix6d::Zero();
  bool pose_valid = false;  ///< T_w_c is an estimate for this frame
  bool is_keyframe = false;
  /// Tracking proposed a keyframe but the local map already covered the view
  /// (mapping.skip_covered_keyframes): no keyframe was made.
  bool keyframe_skipped = false;
  int points_detected = 0;
  int lines_detected = 0;
  int points_stereo = 0;  ///< detected points with a stereo depth
  int lines_stereo = 0;   ///< detected segments with a stereo depth
  int point_matches = 0;  ///< frame-to-frame point matches (before the inlier selection)
  int line_matches = 0;   ///< frame-to-frame segment matches
  int point_inliers = 0;
  int line_inliers = 0;
  bool map_tracked = false;  ///< the pose was refined against the local map
  bool relocalized = false;  ///< tracking was recovered in the map by relocalisation
  /// Visual odometry lost the frame and tracking against the local map, from the motion
  /// model's prediction, recovered it.
  bool map_rescued = false;
  /// Features were too few, and the pose comes from aligning the image directly to the last
  /// frame with a pose (StereoTracker::TrackDirect).
  bool direct_aligned = false;
  /// Neither held either: the pose fits the frame's few matches with the motion model as a
  /// prior (StereoTracker::TrackFused; never a keyframe).
  bool prior_fused = false;
  /// Lost, and T_w_c is the motion model's prediction (covariance: the model's).
  bool predicted = false;
  int loops = 0;  ///< loops closed so far
  /// How far the last loop correction moved the newest keyframe (0 before the first loop).
  double loop_correction_m = 0.0;
  double loop_correction_deg = 0.0;
  int map_point_inliers = 0;  ///< local-map inliers (points)
  int map_line_inliers = 0;   ///< local-map inliers (lines)
  int keyframes = 0;          ///< keyframes in the map
  int map_points = 0;         ///< point landmarks in the map
  int map_lines = 0;          ///< line landmarks in the map
  std::string warning;        ///< why the frame was not tracked, when it was not
  std::vector<std::pair<std::string, double>> stage_ms;  ///< per-stage wall time
  double total_ms = 0.0;
};

/// Runs tracking on a sequence of rectified stereo frames. Not thread-safe: call Process()
/// from one thread; the accessors take consistent copies.
class SlamSystem {
 public:
  /// Throws ConfigError when the camera or the options are invalid.
  SlamSystem(const StereoCamera& camera, const SystemOptions& options);
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  /// Processes one frame. Bad frames (empty, wrong size or type) give a warning and a kLost
  /// result; the pose never becomes NaN.
  FrameResult Process(const StereoFrame& frame);

  /// Estimated left-camera trajectory (one pose per tracked frame) so far. With mapping, each
  /// frame is stored relative to its reference keyframe, so bundle adjustment (and later loop
  /// closure) corrections of the keyframes move the frames with them.
  Trajectory trajectory() const;

  /// Waits until local mapping has processed every queued keyframe (end of a sequence).
  void Flush();

  /// The map (thread-safe readers: Snapshot(), counts()).
  const Map& map() const;

  /// Counters and timings of local mapping (zeros when mapping is off).
  MappingStats mapping_stats() const;

  /// Counters and timings of loop closing (zeros when it is off).
  LoopStats loop_stats() const;

  /// Writes the map to `path` (map_io.h format, atomically). Throws InputError.
  void SaveMap(const std::string& path) const;
  /// Replaces the map by the one in `path` and waits for the next frames to relocalise in it
  /// (tracking reports LOST until one does). Throws InputError (the current map is kept) or
  /// ConfigError when mapping is off.
  void LoadMap(const std::string& path);
  /// Localisation only: tracking against the map (and relocalisation) go on, but no keyframe
  /// is added, so the map stays as it is.
  void SetLocalizationOnly(bool on);
  bool localization_only() const;
  /// Features of the last processed frame (for the debug image), left-camera pixels.
  StereoFeatures last_features() const;

  /// Forgets everything: the next frame starts a new map at the identity.
  void Reset();

  const StereoCamera& camera() const;

 private:
  /// Local-map tracking and keyframe hand-over for a frame the tracker processed.
  void TrackAndMap(const StereoFrame& frame, const TrackerResult& r, FrameResult* result);
  // Chains this frame's tracked motion (from T_w_before, the pose after the map's corrections)
  // into the odometry and fills result's odometry fields; map_moved: the mapping thread moved
  // the reference keyframe during the frame, so the tracker's own increment is chained.
  void AdvanceOdometry(const SE3& T_w_before, const TrackerResult& r, bool map_moved,
                       FrameResult* result);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl_slam
