// The continuous odometry chain behind REP-105's odom frame: the camera pose composed from
// the per-frame motion that tracking measured (frame to frame and against the local map),
// never from the map's corrections (bundle adjustment, loop closure, relocalisation), which
// belong in map -> odom. Its covariance is propagated over time.
//
// Conventions: poses are T_odom_c (the odom frame is the SLAM world at the start). The pose
// covariance is over [dp; dtheta]: the camera position error and a rotation error about the
// odom frame's axes (R_true = Exp(dtheta) R), both in the odom frame - what
// nav_msgs/Odometry's pose covariance means. Increments come as T_prev_cur with the LEFT
// perturbation covariance of motion_estimator.h ([rho; phi], T_true = Exp(d) T_prev_cur).
#pragma once

#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Dead reckoning with covariance propagation. Not thread-safe.
class OdometryChain {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  OdometryChain() { Reset(); }

  /// Back to the origin with a negligible covariance (the start defines the frame).
  void Reset();

  /// Moves on by `T_prev_cur`, whose covariance (left perturbation, [rho; phi]) is given:
  /// Sigma <- F Sigma F^T + G Sigma_inc G^T (first-order propagation).
  ///
  /// `unseen`: the increment was not measured (a lost frame: the motion model's prediction,
  /// or the pose held while the camera moves on). The errors of consecutive unseen increments
  /// are one error repeated (the camera keeps the motion the model got wrong), not
  /// independent draws: over a run of them the standard deviations add, so the uncertainty
  /// grows with the gap's length, not its square root (a rotation's summed deviation stops at
  /// pi: half a turn off is as unknown as it gets). Only the diagonal of such an increment's
  /// covariance is used. A measured increment ends the run.
  void Advance(const SE3& T_prev_cur, const Matrix6d& increment_covariance, bool unseen = false);

  /// Replaces the covariance, e.g. by a small one once a loop closure or relocalisation has
  /// tied the pose to the map again (this also ends a run of unseen increments). Non-finite
  /// input is ignored.
  void SetCovariance(const Matrix6d& covariance);

  /// The odometry pose of the camera.
  const SE3& T_odom_c() const { return T_odom_c_; }
  /// Its covariance over [dp; dtheta], odom frame.
  const Matrix6d& covariance() const { return covariance_; }

 private:
  SE3 T_odom_c_;
  Matrix6d covariance_;
  // Per axis of the increments ([rho; phi]), the summed standard deviations of the current
  // run of unseen increments (zero outside one).
  Vector6d unseen_sigma_sum_ = Vector6d::Zero();
};

}  // namespace pl_slam
