// Stereo visual odometry with points and line segments (paper Section IV): features in both
// images, stereo and frame-to-frame matching, robust motion estimation, keyframe selection.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/line_features.h"
#include "pl_slam/features/point_features.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/io/stereo_frame.h"
#include "pl_slam/matching/line_matching.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/tracking/keyframe_selector.h"
#include "pl_slam/tracking/direct_alignment.h"
#include "pl_slam/tracking/motion_consensus.h"
#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {

/// Which features drive tracking, so the benefit of lines can be measured.
enum class FeatureMode { kPoints, kLines, kPointsAndLines };

/// Parses "points", "lines" or "points_lines"; throws ConfigError naming the value.
FeatureMode ParseFeatureMode(const std::string& name);
/// "points", "lines" or "points_lines".
const char* FeatureModeName(FeatureMode mode);

/// Options of the stereo tracker and of the modules it drives.
struct TrackerOptions {
  FeatureMode mode = FeatureMode::kPointsAndLines;  ///< features used for motion
  bool parallel = true;                             ///< process the right image in a second thread
  int min_inliers = 15;  ///< fewer point + line inliers than this: tracking lost
  /// ... unless there are at least this many and the estimate agrees with the
  /// constant-velocity prediction within relaxed_max_deviation(_deg), its covariance's
  /// standard deviations too. Without a motion model (after a loss) such an estimate, when
  /// the consensus agrees with it, is not kept but becomes the model the next frame must
  /// agree with (0, or not below min_inliers: no relaxed gate). SlamSystem applies the same
  /// gate to tracking against the local map while the pose follows the motion model.
  int relaxed_min_inliers = 8;
  /// Relaxed gate: largest deviation from the prediction and standard deviation, m. No
  /// frame-to-frame estimate with a larger standard deviation is kept, whatever its inliers.
  double relaxed_max_deviation = 0.05;
  double relaxed_max_deviation_deg = 3.0;  ///< the same in rotation, deg
  double max_translation = 2.0;  ///< larger frame-to-frame motion (m) is rejected as a failure
  double max_rotation_deg = 60;  ///< larger frame-to-frame rotation (deg) is rejected
  /// Information of a line residual relative to a point's (octave 0). A line's distance to
  /// its fitted segment is measured along the whole edge, so it is more precise than a
  /// corner's position: 8 was best of 1/3/5/8 on four of the five benchmark sequences and
  /// neutral on EuRoC (docs/BENCHMARKS.md, "Line weight").
  double line_weight = 8.0;
  /// Standard deviation of a stereo feature's disparity relative to the frame-to-frame
  /// residual's noise, propagated into the motion estimate (PointMatch3D2D::depth_noise): a
  /// residual weighs less along the direction its depth error moves it, which under forward
  /// motion is the features far from the image centre. Lines use it divided by |sin| of their
  /// angle to the image rows. 0 (the default) takes stereo depths as exact: 1 and 0.3 did not
  /// lower the street family's VO error (docs/BENCHMARKS.md, "Design decisions").
  double depth_noise = 0.0;
  /// Refine each frame-to-frame pose against the last keyframe: the keyframe's stereo
  /// features are matched to the frame directly and the pose re-estimated from them, so
  /// errors add up per keyframe instead of per frame.
  bool track_keyframe = true;
  /// The keyframe pose is used only with at least this many inliers per frame-to-frame inlier.
  double keyframe_min_inlier_ratio = 0.5;
  double keyframe_max_correction = 0.05;     ///< larger change (m) is refused as a mismatch
  double keyframe_max_correction_deg = 2.0;  ///< larger change (deg) is refused
  /// The keyframe pose is also refused when it disagrees with the frame-to-frame pose beyond both
  /// estimates' uncertainty: the change's squared Mahalanobis distance under the sum of their
  /// covariances (6 dof) above this; 0 = no such check. The keyframe estimate has no
  /// consensus stage of its own, so weak corners that join it (a low FAST threshold on a bare
  /// wall) can settle it on a wrong pose within the absolute gates above (4.2 cm, 0.78 deg:
  /// distance 443). The estimates' covariances are optimistic, with lines more so: refinements
  /// that help measure up to 31 on the synthetic sequences and between 50 and 100 on street
  /// drives with lines (refused at 50, their visual odometry drifted), hence a bound far
  /// above chi2's 99.99 % (27.9).
  double keyframe_max_chi2 = 200.0;
  /// While lost, the pose follows the constant-velocity model for at most this many frames
  /// (reported with pose_valid false and `predicted` true), so tracking that resumes, or a
  /// rescue against the local map, starts where the camera is likely to be rather than where
  /// it was last seen. 0: stay at the last good pose.
  int max_predicted_frames = 10;
  /// While lost, the frame's matches still give its rotation about the predicted position
  /// (the last one once max_predicted_frames are over) when at least this many agree on one
  /// within relaxed_max_deviation_deg of the model's (0: the model's rotation). A turn does
  /// not keep the rate the model extrapolates, and the heading error of a gap is what the
  /// rest of the trajectory carries.
  int lost_rotation_min_inliers = 4;
  /// A frame too poor for an estimate of its own (fewer inliers than the gates keep, or their
  /// motion unobservable: a few clustered features) right after a tracked frame, when neither
  /// the local map nor direct alignment holds it (TrackFused): its matches are fitted
  /// together with the constant-velocity prediction as a Gaussian prior whose covariance is
  /// the last motion's own plus fused_sigma, fused_sigma_deg per axis (the change of motion a
  /// frame allows). The prior supplies the directions the features leave open (the features,
  /// say, the distance to a light switch the camera walks up to; the prior the roll). Kept,
  /// flagged `prior_fused`, with at least this many inliers, the deviation from the
  /// prediction within the prior's 99 % bound (chi2, 6 dof) and the relaxed gate's, and the
  /// combined standard deviations within the relaxed gate's; the motion model then carries
  /// that estimate with its covariance, so a run of such frames is only as certain as its
  /// evidence. 0: off.
  int fused_min_inliers = 5;
  double fused_sigma = 0.01;     ///< change of motion per axis and frame the prior allows, m
  double fused_sigma_deg = 0.5;  ///< the same, deg
  /// A frame the relaxed gate keeps (fewer than min_inliers, agreeing with the model) is
  /// fitted with the same prior (the gates of fused_min_inliers), so that the directions its
  /// few features leave weak (the distance to a light switch, which the left image alone
  /// hardly measures) stay near the model instead of taking the features' noise into it.
  bool relaxed_prior = true;
  PointDetectorOptions points;          ///< "points.*"
  PointMatchingOptions point_matching;  ///< "point_matching.*"
  LineDetectorOptions lines;            ///< "lines.*"
  LineMatchingOptions line_matching;    ///< "line_matching.*"
  MotionEstimatorOptions motion;        ///< "motion.*"
  ConsensusOptions consensus;           ///< "consensus.*"
  DirectAlignmentOptions direct;        ///< "direct.*" (TrackDirect)
  KeyframeSelectorOptions keyframes;    ///< "keyframes.*"

  /// Empty when valid, else "key=value must be ..." naming the first bad key (with prefix).
  std::string Validate() const;
};

/// State after a frame.
enum class TrackerState { kNotInitialized = 0, kTracking = 1, kLost = 2 };

/// What the tracker reports for one frame.
struct TrackerResult {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  TrackerState state = TrackerState::kNotInitialized;
  bool pose_valid = false;  ///< T_w_c was estimated for this frame
  SE3 T_w_c;                ///< pose (the last good one when not valid)
  SE3 T_prev_cur;           ///< increment from the previous frame (identity when not valid)
  /// Of T_prev_cur, [rho; phi]. Lost and not predicted (the pose stays): the motion the
  /// camera may have made unseen, the last known motion's size per axis (at least 1 cm and
  /// 0.5 deg).
  Matrix6d covariance_prev_cur = Matrix6d::Identity();
  bool is_keyframe = false;
  KeyframeReason keyframe_reason = KeyframeReason::kNone;
  int points_detected = 0, lines_detected = 0;  ///< left image
  int points_stereo = 0, lines_stereo = 0;      ///< with depth
  int point_matches = 0, line_matches = 0;      ///< frame-to-frame
  int point_inliers = 0, line_inliers = 0;      ///< kept by motion estimation
  bool keyframe_refined = false;                ///< the pose comes from matching the last keyframe
  /// Lost, and T_w_c is the constant-velocity prediction, or the last pose turned by the
  /// frame's own rotation once the model's frames are over (covariance_prev_cur is then the
  /// motion model's: the increment's size as its standard deviation).
  bool predicted = false;
  /// Predicted, with the rotation measured from the frame's own matches about the predicted
  /// position (TrackerOptions::lost_rotation_min_inliers).
  bool rotation_measured = false;
  /// The pose comes from direct alignment of the image to the last frame with a pose
  /// (TrackDirect): features were too few, the image's edges were enough.
  bool direct_aligned = false;
  /// The pose fits the frame's few matches together with the constant-velocity prediction
  /// (TrackFused): tracked, with the prior's share in the covariance.
  bool prior_fused = false;
  std::string warning;                                   ///< why tracking failed, when it did
  std::vector<std::pair<std::string, double>> stage_ms;  ///< per-stage wall time
};

/// Frame-to-frame stereo tracker. One instance per camera; Track() from one thread.
class StereoTracker {
 public:
  /// Throws ConfigError on an invalid camera or options.
  StereoTracker(const StereoCamera& camera, const TrackerOptions& options);
  ~StereoTracker();

  /// Tracks one rectified stereo frame (CV_8UC1, camera size; checked by the caller).
  /// `mapping_idle`: local mapping would take a keyframe at once (keyframes.idle_min_frames).
  TrackerResult Track(const StereoFrame& frame, bool mapping_idle = false);

  /// Forgets the previous frame: the next frame restarts at the identity.
  void Reset();

  /// Replaces the current pose by a better estimate (tracking against the map); the motion
  /// prior (velocity) and the keyframe chain are kept.
  void CorrectPose(const SE3& T_w_c);

  /// After relocalisation: the last frame (the one just tracked) is at T_w_c in the map;
  /// tracking resumes from it (state TRACKING, no motion prior, a new keyframe chain).
  void Relocalized(const SE3& T_w_c);

  /// After tracking against the local map rescued a frame the tracker lost: the last frame is
  /// at T_w_c; tracking resumes from it with the motion prior kept (a new keyframe chain).
  void Rescued(const SE3& T_w_c);

  /// The last resort before a frame is reported lost: `frame` (the one Track() just returned
  /// `r` for, pose predicted) aligned directly to the last frame with a pose, from the motion
  /// model's prediction (direct_alignment.h). Kept when the alignment converges, lands within
  /// relaxed_max_deviation(_deg) of the prediction per frame since that reference and its
  /// standard deviations are within them too; then `r` becomes a tracked frame (pose_valid,
  /// direct_aligned) and tracking continues from it. False (r untouched) otherwise, or when
  /// tracker.direct.enabled is off.
  bool TrackDirect(const StereoFrame& frame, TrackerResult* r);

  /// After direct alignment, the last resort: `frame` (the one Track() just returned `r` for,
  /// lost right after a tracked frame) fitted from its frame-to-frame matches together with
  /// the constant-velocity prediction as a prior (TrackerOptions::fused_min_inliers). When the
  /// gates there hold, `r` becomes a tracked frame (pose_valid, prior_fused, never a keyframe)
  /// and tracking continues from it. False (r untouched but for its stage times) otherwise.
  bool TrackFused(const StereoFrame& frame, TrackerResult* r);

  /// Features of the last frame (for the debug image and the map).
  const StereoFeatures& last_features() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl_slam
