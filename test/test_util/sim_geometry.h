// Geometry of rendered scenes for the generator's tests: heading of a camera pose, the
// unwrapped heading along a trajectory, and the distance from a point to a textured quad.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/sim/world.h"

namespace pl_slam {
namespace testing_util {

/// Heading (rad) of the camera's optical axis in the world's x-y plane.
inline double Yaw(const SE3& T_w_c) {
  const Eigen::Vector3d z = T_w_c.rotation().col(2);
  return std::atan2(z.y(), z.x());
}

inline double WrapPi(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// Unwrapped yaw along the trajectory, degrees, starting at 0.
inline std::vector<double> YawProfile(const Trajectory& gt) {
  constexpr double kRad2Deg = 180.0 / M_PI;
  std::vector<double> yaw = {0.0};
  for (std::size_t i = 1; i < gt.size(); ++i)
    yaw.push_back(yaw.back() + WrapPi(Yaw(gt[i].T_w_c) - Yaw(gt[i - 1].T_w_c)) * kRad2Deg);
  return yaw;
}

/// Distance from p to the nearest point of the quad.
inline double DistanceToQuad(const sim::TexturedQuad& q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d rel = p - q.origin;
  const double s = std::clamp(rel.dot(q.axis_u), 0.0, q.size_u);
  const double t = std::clamp(rel.dot(q.axis_v), 0.0, q.size_v);
  return (p - q.PointAt(s, t)).norm();
}

}  // namespace testing_util
}  // namespace pl_slam
