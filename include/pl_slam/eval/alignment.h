// Alignment of an estimated trajectory to ground truth before computing absolute errors.
//
// A similarity maps estimate-world points into the ground-truth world:
//   p_gt = scale * R * p_est + t,   with (R, t) = T_gt_est.
// Umeyama (1991) gives the least-squares R, t (and scale) in closed form from an SVD, with
// the reflection case handled so R is always a proper rotation.
#pragma once

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <string>
#include <vector>

#include "pl_slam/eval/association.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {

/// How the estimate is brought into the ground-truth frame.
enum class AlignmentMode {
  kNone,       ///< identity: both trajectories already share the world frame
  kFirstPose,  ///< T_gt_est = T_w_gt(0) * T_w_est(0)^-1 (scale 1)
  kSE3,        ///< Umeyama, rotation + translation (scale fixed at 1)
  kSim3,       ///< Umeyama, rotation + translation + scale
};

/// Parses "none", "first-pose" (or "first"), "se3", "sim3" (case-insensitive); throws
/// ConfigError naming the value and the accepted ones.
AlignmentMode ParseAlignmentMode(const std::string& name);
/// The name ParseAlignmentMode accepts ("none", "first-pose", "se3", "sim3").
std::string AlignmentModeName(AlignmentMode mode);

/// A similarity transform from the estimate world to the ground-truth world.
struct Alignment {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  AlignmentMode mode = AlignmentMode::kNone;
  SE3 T_gt_est;        ///< rotation and translation
  double scale = 1.0;  ///< 1 except for kSim3

  /// Maps a point of the estimate world into the ground-truth world.
  Eigen::Vector3d Apply(const Eigen::Vector3d& p_est) const;
  /// Maps a pose: rotation R * R_est, position scale * R * t_est + t.
  SE3 Apply(const SE3& T_est) const;
};

using Points3d = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

/// Umeyama least-squares alignment of `src` onto `dst` (same size, paired by index), i.e. the
/// R, t (, s) minimising sum ||dst_i - (s R src_i + t)||^2.
///  - Throws InputError when the sizes differ or the sets are empty.
///  - One point (or all src points identical) with with_scale == false: R = I, t = mean(dst)
///    - mean(src); two or collinear points: R is one of the equally good minimisers.
///  - with_scale == true throws InputError when the src or dst points are all identical
///    (spread below 1e-9 m): the scale is undefined.
Alignment UmeyamaAlignment(const Points3d& src, const Points3d& dst, bool with_scale);

/// Alignment of an associated pair of trajectories with the given mode (see the Umeyama
/// notes for degenerate cases). Throws InputError when the association is empty.
Alignment AlignTrajectories(const Association& association, AlignmentMode mode);

/// Applies the alignment to every pose of the trajectory.
Trajectory ApplyAlignment(const Trajectory& traj, const Alignment& alignment);

}  // namespace eval
}  // namespace pl_slam
