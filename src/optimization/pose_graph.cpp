#include "pl_slam/optimization/pose_graph.h"

#include <chrono>

#include <ceres/autodiff_cost_function.h>
#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

std::string PoseGraphOptions::Validate() const {
  std::string e = CheckRange("max_iterations", max_iterations, 1, 10000);
  if (e.empty()) e = CheckRange("rotation_weight", rotation_weight, 0.0, 1e6, true);
  return e;
}

namespace {

/// Relative-pose residual between two [qx qy qz qw tx ty tz] blocks (automatic derivatives).
struct RelativePoseResidual {
  RelativePoseResidual(const SE3& T_i_j, double sqrt_weight, double rotation_weight)
      : q_ij(T_i_j.so3()), t_ij(T_i_j.translation()), s(sqrt_weight), w_rot(rotation_weight) {}

  template <typename T>
  bool operator()(const T* const pose_i, const T* const pose_j, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(pose_i), q_j(pose_j);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_i(pose_i + 4), t_j(pose_j + 4);
    const Eigen::Quaternion<T> q_i_inv = q_i.conjugate();
    const Eigen::Quaternion<T> q_rel = q_i_inv * q_j;
    const Eigen::Matrix<T, 3, 1> t_rel = q_i_inv * (t_j - t_i);
    const Eigen::Quaternion<T> q_m_inv = q_ij.conjugate().template cast<T>();
    const Eigen::Quaternion<T> q_err = q_m_inv * q_rel;
    const Eigen::Matrix<T, 3, 1> t_err = q_m_inv * (t_rel - t_ij.template cast<T>());
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r.template head<3>() = T(s) * t_err;
    // The sign of q_err is arbitrary; use the one with w >= 0 so the error is small.
    const T sign = q_err.w() < T(0) ? T(-1) : T(1);
    r.template tail<3>() = T(2.0 * s * w_rot) * sign * q_err.vec();
    return true;
  }

  Eigen::Quaterniond q_ij;
  Eigen::Vector3d t_ij;
  double s, w_rot;
};

void ToParams(const SE3& T, double* p) {
  const Eigen::Quaterniond& q = T.so3();
  p[0] = q.x();
  p[1] = q.y();
  p[2] = q.z();
  p[3] = q.w();
  p[4] = T.translation().x();
  p[5] = T.translation().y();
  p[6] = T.translation().z();
}

}  // namespace

PoseGraphSummary OptimizePoseGraph(
    const std::vector<PoseGraphEdge, Eigen::aligned_allocator<PoseGraphEdge>>& edges,
    const std::vector<char>& fixed, const PoseGraphOptions& options,
    std::vector<SE3, Eigen::aligned_allocator<SE3>>* T_w_c) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("pose_graph." + err);
  const auto t0 = std::chrono::steady_clock::now();
  PoseGraphSummary summary;
  const int n = static_cast<int>(T_w_c->size());
  if (n == 0 || edges.empty()) {
    summary.message = "empty graph";
    return summary;
  }
  std::vector<double> params(7 * static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) ToParams((*T_w_c)[k], &params[7 * k]);
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> manifold;
  std::vector<char> used(n, 0);
  for (const PoseGraphEdge& e : edges) {
    if (e.i < 0 || e.i >= n || e.j < 0 || e.j >= n || e.i == e.j || !(e.weight > 0.0)) continue;
    for (int k : {e.i, e.j})
      if (!used[k]) {
        used[k] = 1;
        problem.AddParameterBlock(&params[7 * k], 7, &manifold);
      }
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 7, 7>(
        new RelativePoseResidual(e.T_i_j, std::sqrt(e.weight), options.rotation_weight));
    problem.AddResidualBlock(cost, nullptr, &params[7 * e.i], &params[7 * e.j]);
  }
  bool any_fixed = false;
  for (int k = 0; k < n; ++k)
    if (used[k] && k < static_cast<int>(fixed.size()) && fixed[k]) {
      problem.SetParameterBlockConstant(&params[7 * k]);
      any_fixed = true;
    }
  if (!any_fixed)
    for (int k = 0; k < n; ++k)
      if (used[k]) {
        problem.SetParameterBlockConstant(&params[7 * k]);
        break;
      }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  so.max_num_iterations = options.max_iterations;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  summary.success = s.IsSolutionUsable();
  summary.message = s.message;
  summary.iterations = static_cast<int>(s.iterations.size());
  summary.initial_cost = s.initial_cost;
  summary.final_cost = s.final_cost;
  if (summary.success)
    for (int k = 0; k < n; ++k)
      if (used[k]) {
        const double* p = &params[7 * k];
        (*T_w_c)[k] =
            SE3(Eigen::Quaterniond(p[3], p[0], p[1], p[2]), Eigen::Vector3d(p[4], p[5], p[6]));
      }
  summary.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace pl_slam
