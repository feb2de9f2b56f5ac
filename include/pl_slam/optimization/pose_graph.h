// Pose-graph optimisation over keyframe poses (loop correction): SE(3) relative-pose
// residuals between keyframes, solved with Ceres (quaternion + translation blocks on
// ceres::ProductManifold<EigenQuaternionManifold, EuclideanManifold<3>>).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// A relative-pose constraint T_i_j = T_w_i^-1 * T_w_j between nodes i and j.
struct PoseGraphEdge {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  int i = 0;
  int j = 0;
  SE3 T_i_j;             ///< measured relative pose
  double weight = 1.0;   ///< information scale (loop edges may weigh more)
  bool is_loop = false;  ///< for reporting
};

/// Options of OptimizePoseGraph.
struct PoseGraphOptions {
  int max_iterations = 30;        ///< Levenberg-Marquardt iterations
  double rotation_weight = 10.0;  ///< residual scale of rotation (rad) relative to translation (m)
  /// Empty when valid, else "key=value must be ..." naming the first bad key.
  std::string Validate() const;
};

/// Result of OptimizePoseGraph.
struct PoseGraphSummary {
  bool success = false;
  std::string message;
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  double solve_ms = 0.0;
};

/// Optimises `T_w_c` (one pose per node) in place so that the edges hold as well as possible;
/// nodes with fixed[k] = true stay put (at least one must be fixed: the first is when none is).
/// Residual per edge: [t_err; rotation_weight * 2 vec(q_err)] * sqrt(weight), where
/// (q_err, t_err) = T_i_j_measured^-1 * T_w_i^-1 * T_w_j. Edges naming a missing node, a
/// self-edge or a weight that is not positive are skipped; no poses or no edges: no success
/// ("empty graph"). Throws ConfigError on invalid options.
PoseGraphSummary OptimizePoseGraph(
    const std::vector<PoseGraphEdge, Eigen::aligned_allocator<PoseGraphEdge>>& edges,
    const std::vector<char>& fixed, const PoseGraphOptions& options,
    std::vector<SE3, Eigen::aligned_allocator<SE3>>* T_w_c);

}  // namespace pl_slam
