// Helpers shared by the eval tests: synthetic trajectories with known truth.
#pragma once

#include <cmath>
#include <random>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {
namespace testing {

/// A smooth 3-D loop (about 2 x 1.5 x 0.5 m) sampled at `rate_hz` for `duration` seconds,
/// starting at t0, with the camera turning along the path.
inline Trajectory MakeLoop(double rate_hz, double duration, double t0 = 100.0) {
  Trajectory traj;
  const int n = static_cast<int>(std::floor(duration * rate_hz + 1e-9)) + 1;
  for (int i = 0; i < n; ++i) {
    const double t = t0 + i / rate_hz;
    const double s = (t - t0) * 0.4;
    StampedPose p;
    p.t = t;
    const Eigen::Vector3d pos(2.0 * std::cos(s), 1.5 * std::sin(s), 0.5 * std::sin(2.0 * s));
    const Eigen::Vector3d rot(0.1 * std::sin(s), 0.05 * std::cos(3.0 * s), s);
    p.T_w_c = SE3(ExpSO3(rot), pos);
    traj.push_back(p);
  }
  return traj;
}

/// A random rigid transform (rotation up to pi, translation up to `trans` per axis).
inline SE3 RandomSE3(std::mt19937& rng, double trans = 5.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const double angle = M_PI * std::fabs(u(rng));
  return SE3(ExpSO3(axis * angle), Eigen::Vector3d(trans * u(rng), trans * u(rng), trans * u(rng)));
}

}  // namespace testing
}  // namespace eval
}  // namespace pl_slam
