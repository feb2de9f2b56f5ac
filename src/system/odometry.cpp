#include "pl_slam/system/odometry.h"

#include <cmath>

namespace pl_slam {
void OdometryChain::Reset() {
  T_odom_c_ = SE3();
  covariance_ = 1e-12 * Matrix6d::Identity();
  unseen_sigma_sum_.setZero();
}

void OdometryChain::Advance(const SE3& T_prev_cur, const Matrix6d& increment_covariance,
                            bool unseen) {
  if (!T_prev_cur.IsFinite()) return;
  Matrix6d added = increment_covariance;
  if (!unseen) {
    unseen_sigma_sum_.setZero();
  } else if (increment_covariance.allFinite()) {
    // The run's error so far and this increment's are the same error: the run's variance
    // becomes (sum of sigmas)^2, so this increment adds (S + s)^2 - S^2 per axis. A rotation
    // error beyond half a turn says no more than half a turn: the sum stops there.
    const Vector6d s = increment_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    Vector6d next_sum = unseen_sigma_sum_ + s;
    next_sum.tail<3>() = next_sum.tail<3>().cwiseMin(M_PI);
    added = (next_sum.cwiseAbs2() - unseen_sigma_sum_.cwiseAbs2()).asDiagonal();
    unseen_sigma_sum_ = next_sum;
  }
  const Eigen::Matrix3d R = T_odom_c_.rotation();
  const Eigen::Vector3d t_world = R * T_prev_cur.translation();
  // p' = p + R t, R' = R R_inc. A rotation error of the previous pose swings the step:
  // dp' = dp - [R t]x dtheta; the increment's left perturbation [rho; phi] (previous camera
  // frame) moves the position by R (rho - [t]x phi) and turns the pose by R phi.
  Matrix6d F = Matrix6d::Identity();
  F.block<3, 3>(0, 3) = -Hat(t_world);
  Matrix6d G = Matrix6d::Zero();
  G.block<3, 3>(0, 0) = R;
  G.block<3, 3>(0, 3) = -R * Hat(T_prev_cur.translation());
  G.block<3, 3>(3, 3) = R;
  Matrix6d next = F * covariance_ * F.transpose();
  if (added.allFinite()) next += G * added * G.transpose();
  covariance_ = 0.5 * (next + next.transpose());
  T_odom_c_ = T_odom_c_ * T_prev_cur;
}

void OdometryChain::SetCovariance(const Matrix6d& covariance) {
  if (!covariance.allFinite()) return;
  covariance_ = 0.5 * (covariance + covariance.transpose());
  unseen_sigma_sum_.setZero();
}

}  // namespace pl_slam
