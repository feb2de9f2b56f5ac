// Consensus before refinement: a RANSAC stage over minimal sets of stereo points and line
// segments that finds the motion most correspondences agree with, so the robust Gauss-Newton
// of motion_estimator.h starts in the right basin and never sees gross mismatches.
//
// Hypotheses are 3D-3D: both frames are stereo, so a correspondence whose current feature was
// triangulated too gives two 3D positions. A minimal set is three points (closed-form
// rotation and translation, Kabsch) or two non-parallel segments (rotation from the two
// directions, translation from the two lines' positions). Sets whose geometry a rigid motion
// cannot produce (distances or angles that changed beyond the stereo depth noise) are refused
// before scoring. Every hypothesis, and the given candidates (the constant-velocity prior,
// the identity), is scored by its reprojection in the current left image: a point by its pixel
// distance, a segment by the RMS distance of its two projected endpoints to the observed line
// (MSAC: each correspondence costs min(e^2, inlier_px^2)). Points and segments count alike.
//
// The pose convention is motion_estimator.h's: T_cur_prev maps previous-camera points into the
// current camera.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {

/// Options of FindMotionConsensus ("tracker.consensus.*").
struct ConsensusOptions {
  bool enabled = true;        ///< run the hypothesis stage before the robust refinement
  int max_hypotheses = 300;   ///< minimal sets scored at most
  double confidence = 0.999;  ///< stop once a better consensus is this unlikely to be missed
  double inlier_px = 3.0;     ///< a correspondence supports a hypothesis within this, pixels
  /// Correspondences farther than this from the consensus pose (pixels) are left out of the
  /// refinement: the estimator's own outlier threshold never exceeds its outlier_max_px.
  double gate_px = 10.0;
  /// Stereo disparity noise, pixels: the rigidity pre-check allows distances between sampled
  /// points to change by 3 sigma of their depth noise.
  double disparity_sigma_px = 0.5;

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// A current-frame 3D position per correspondence: NaN when the current feature has no
/// stereo depth (it then only takes part in scoring, not in minimal sets).
using Points3D = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

/// Result of FindMotionConsensus.
struct ConsensusResult {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  bool success = false;               ///< a hypothesis had at least min_inliers supporters
  SE3 T_cur_prev;                     ///< the best hypothesis (the first candidate on failure)
  std::vector<uint8_t> point_inlier;  ///< 1 when within inlier_px of the best hypothesis
  std::vector<uint8_t> line_inlier;   ///< idem, per segment
  std::vector<uint8_t> point_gate;    ///< 1 when within gate_px (kept for the refinement)
  std::vector<uint8_t> line_gate;     ///< idem, per segment
  int point_inliers = 0, line_inliers = 0;  ///< supporters of the best hypothesis
  int hypotheses = 0;                       ///< minimal sets scored (candidates not counted)
  bool from_candidate = false;              ///< the best hypothesis was one of the given candidates
  std::string failure;                      ///< why it failed; empty on success
};

/// Solves the rigid motion X_cur = R X_prev + t from >= 3 point pairs (least squares, Kabsch).
/// False when the points are (nearly) collinear.
bool RigidFromPoints(const Points3D& prev, const Points3D& cur, SE3* T_cur_prev);

/// Solves the rigid motion from two segment pairs: directions d (prev) and e (cur), one point
/// on each line in each frame. False when the lines are (nearly) parallel or their angle
/// differs between the frames by more than max_angle_change (radians).
bool RigidFromLines(const Eigen::Vector3d& a1, const Eigen::Vector3d& d1, const Eigen::Vector3d& a2,
                    const Eigen::Vector3d& d2, const Eigen::Vector3d& b1, const Eigen::Vector3d& e1,
                    const Eigen::Vector3d& b2, const Eigen::Vector3d& e2, double max_angle_change,
                    SE3* T_cur_prev);

/// Finds the motion the most correspondences agree with. The random draws are seeded the same
/// on every call, so runs are reproducible. `points_cur` (one per point match)
/// and `lines_cur_P`, `lines_cur_Q` (one per line match) hold the current-frame stereo
/// triangulations, NaN where there is none; `candidates` are scored as they are (e.g. the
/// motion prior). Fails, with a reason, when no hypothesis reaches `min_inliers` supporters.
/// Throws ConfigError when options.Validate() fails or the sizes disagree.
ConsensusResult FindMotionConsensus(const StereoCamera& cam, const PointMatches3D2D& points,
                                    const Points3D& points_cur, const LineMatches3D2D& lines,
                                    const Points3D& lines_cur_P, const Points3D& lines_cur_Q,
                                    const std::vector<SE3>& candidates, int min_inliers,
                                    const ConsensusOptions& options);

}  // namespace pl_slam
