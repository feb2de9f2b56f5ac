#include "pl_slam/optimization/bundle_adjustment.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>

#include "pl_slam/optimization/line_cost.h"
#include "pl_slam/optimization/point_cost.h"
#include "pl_slam/optimization/se3_manifold.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

std::string BundleAdjustmentOptions::Validate() const {
  std::string e = CheckRange("max_iterations", max_iterations, 1, 1000);
  if (e.empty()) e = CheckRange("outlier_sigma", outlier_sigma, 0.0, 100.0, true);
  if (e.empty()) e = CheckRange("point_chi2_mono", point_chi2_mono, 0.0, 1e6, true);
  if (e.empty()) e = CheckRange("point_chi2_stereo", point_chi2_stereo, 0.0, 1e6, true);
  if (e.empty()) e = CheckRange("line_chi2_mono", line_chi2_mono, 0.0, 1e6, true);
  if (e.empty()) e = CheckRange("line_chi2_stereo", line_chi2_stereo, 0.0, 1e6, true);
  if (e.empty()) e = CheckRange("line_extent_weight", line_extent_weight, 0.0, 1e6);
  if (e.empty()) e = CheckRange("min_depth", min_depth, 0.0, 100.0);
  if (e.empty()) e = CheckRange("disparity_sigma", disparity_sigma, 0.0, 100.0);
  if (e.empty()) e = CheckRange("num_threads", num_threads, 1, 64);
  if (e.empty() && schur != "sparse" && schur != "dense")
    e = "schur='" + schur + "' must be sparse or dense";
  if (e.empty() && line_residual != "auto" && line_residual != "observed" &&
      line_residual != "projected")
    e = "line_residual='" + line_residual + "' must be auto, observed or projected";
  return e;
}

namespace {

constexpr double kChi2OneDof = 3.841;  // 95 %

/// Squared whitened residual and the smallest depth of an observation at the current values.
struct Evaluation {
  double chi2 = 0.0;
  double depth = 0.0;
};

Evaluation EvaluatePoint(const StereoCamera& cam, const SE3& T_c_w, const Eigen::Vector3d& p_w,
                         const BaPointObservation& o) {
  Evaluation ev;
  const Eigen::Vector3d X = T_c_w * p_w;
  ev.depth = X.z();
  if (!(X.z() > 0.0)) return ev;
  double s = (cam.Project(X) - o.uv).squaredNorm();
  if (o.stereo) {
    const double du = cam.ProjectRight(X).x() - o.u_right;
    s += du * du;
  }
  ev.chi2 = s * o.sqrt_info * o.sqrt_info;
  return ev;
}

Evaluation EvaluateLine(const StereoCamera& cam, const SE3& T_c_w, const Eigen::Vector3d& P_w,
                        const Eigen::Vector3d& Q_w, const BaLineObservation& o, bool observed) {
  Evaluation ev;
  const Eigen::Vector3d X[2] = {T_c_w * P_w, T_c_w * Q_w};
  double s = 0.0;
  if (observed) {
    // Only the line's position matters: part of it in front of the camera is enough.
    ev.depth = std::max(X[0].z(), X[1].z());
    if (!(ev.depth > 0.0)) return ev;
    const int views = o.stereo ? 2 : 1;
    for (int view = 0; view < views; ++view) {
      const Eigen::Vector3d shift(view == 0 ? 0.0 : cam.baseline, 0.0, 0.0);
      const double cx = view == 0 ? cam.cx : cam.cx + cam.doffs;
      const Eigen::Vector3d m = (X[0] - shift).cross(X[1] - shift);
      for (const Eigen::Vector2d& px : {view == 0 ? o.s : o.s_right, view == 0 ? o.e : o.e_right}) {
        const double d = PixelToProjectedLine(m, px, cam.fx, cam.fy, cx, cam.cy, nullptr);
        s += d * d;
      }
    }
    ev.chi2 = s * o.sqrt_info * o.sqrt_info;
    return ev;
  }
  ev.depth = std::min(X[0].z(), X[1].z());
  if (!(ev.depth > 0.0)) return ev;
  const Eigen::Vector3d l = LineThrough(o.s, o.e), l_right = LineThrough(o.s_right, o.e_right);
  for (const Eigen::Vector3d& x : X) {
    const Eigen::Vector2d uv = cam.Project(x);
    const double d = l.dot(Eigen::Vector3d(uv.x(), uv.y(), 1.0));
    s += d * d;
    if (o.stereo) {
      const Eigen::Vector2d uvr = cam.ProjectRight(x);
      const double dr = l_right.dot(Eigen::Vector3d(uvr.x(), uvr.y(), 1.0));
      s += dr * dr;
    }
  }
  ev.chi2 = s * o.sqrt_info * o.sqrt_info;
  return ev;
}

/// Stops the solver when the owner's flag is set (a global BA made stale by a new loop).
class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* abort) : abort_(abort) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return abort_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* abort_;
};

}  // namespace

BaSummary SolveBundleAdjustment(const StereoCamera& camera, const BundleAdjustmentOptions& options,
                                BaProblem* problem, const std::atomic<bool>* abort) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("bundle_adjustment." + err);
  const auto t0 = std::chrono::steady_clock::now();
  BaSummary summary;
  BaProblem& p = *problem;
  const int np = static_cast<int>(p.poses.size());
  const int npt = static_cast<int>(p.points.size());
  const int nl = static_cast<int>(std::min(p.line_P.size(), p.line_Q.size()));
  summary.point_outlier.assign(p.point_obs.size(), 0);
  summary.line_outlier.assign(p.line_obs.size(), 0);
  if (np == 0) {
    summary.message = "no poses";
    return summary;
  }

  // Pose blocks hold T_c_w (the costs project world points into the camera).
  std::vector<std::array<double, 7>> pose_params(np);
  // Landmarks in one buffer, points then lines ([P_w; Q_w]): Ceres orders the blocks of an
  // elimination group by address, so one allocation keeps the order (and with it every
  // floating-point result) the same from run to run.
  std::vector<double> landmark_params(3 * npt + 6 * nl);
  double* const point_params = landmark_params.data();
  double* const line_params = landmark_params.data() + 3 * npt;
  for (int i = 0; i < npt; ++i)
    std::copy(p.points[i].data(), p.points[i].data() + 3, point_params + 3 * i);
  for (int i = 0; i < nl; ++i) {
    std::copy(p.line_P[i].data(), p.line_P[i].data() + 3, line_params + 6 * i);
    std::copy(p.line_Q[i].data(), p.line_Q[i].data() + 3, line_params + 6 * i + 3);
  }
  for (int i = 0; i < np; ++i) SE3ToParams(p.poses[i].T_w_c.inverse(), pose_params[i].data());
  bool any_fixed = false;
  for (const BaPose& pose : p.poses) any_fixed |= pose.fixed;

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  SE3Manifold manifold;
  ceres::Problem ceres_problem(problem_options);
  std::vector<ceres::ResidualBlockId> point_blocks(p.point_obs.size(), nullptr);
  // With disparity_sigma > 0 a stereo point's disparity is a block of its own.
  std::vector<ceres::ResidualBlockId> disparity_blocks(p.point_obs.size(), nullptr);
  const bool split_disparity = options.disparity_sigma > 0.0;
  const double huber_disparity = std::sqrt(kChi2OneDof);
  std::vector<ceres::ResidualBlockId> line_blocks(p.line_obs.size(), nullptr);
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<char> pose_used(np, 0);

  // Whitened residuals are in pixels at octave 0 (sqrt_info = 1 / scale^octave). The Huber
  // thresholds are the chi2 quantiles at 1 px; the outlier gates are the same quantiles in
  // units of outlier_sigma.
  const double sigma2 = options.outlier_sigma * options.outlier_sigma;
  const double huber_point_mono = std::sqrt(options.point_chi2_mono);
  const double huber_point_stereo = std::sqrt(options.point_chi2_stereo);
  const double huber_line_mono = std::sqrt(options.line_chi2_mono);
  const double huber_line_stereo = std::sqrt(options.line_chi2_stereo);
  const bool observed_lines = options.line_residual == "observed";
  auto use_pose = [&](int i) {
    if (pose_used[i]) return;
    pose_used[i] = 1;
    ceres_problem.AddParameterBlock(pose_params[i].data(), 7, &manifold);
    ordering->AddElementToGroup(pose_params[i].data(), 1);
  };
  for (size_t k = 0; k < p.point_obs.size(); ++k) {
    const BaPointObservation& o = p.point_obs[k];
    if (o.pose < 0 || o.pose >= np || o.point < 0 || o.point >= npt) continue;
    use_pose(o.pose);
    double* point = point_params + 3 * o.point;
    ceres::CostFunction* cost;
    ceres::LossFunction* loss;
    if (o.stereo && split_disparity) {
      cost = new MonoPointCost(camera, o.uv, 0.0, o.sqrt_info);
      loss = new ceres::HuberLoss(huber_point_mono);
      disparity_blocks[k] = ceres_problem.AddResidualBlock(
          new DisparityCost(camera, o.uv.x() - o.u_right, 1.0 / options.disparity_sigma),
          new ceres::HuberLoss(huber_disparity), pose_params[o.pose].data(), point);
    } else if (o.stereo) {
      cost = new StereoPointCost(camera, o.uv, o.u_right, o.sqrt_info);
      loss = new ceres::HuberLoss(huber_point_stereo);
    } else {
      cost = new MonoPointCost(camera, o.uv, 0.0, o.sqrt_info);
      loss = new ceres::HuberLoss(huber_point_mono);
    }
    point_blocks[k] = ceres_problem.AddResidualBlock(cost, loss, pose_params[o.pose].data(), point);
    if (!ordering->IsMember(point)) ordering->AddElementToGroup(point, 0);
  }
  for (size_t k = 0; k < p.line_obs.size(); ++k) {
    const BaLineObservation& o = p.line_obs[k];
    if (o.pose < 0 || o.pose >= np || o.line < 0 || o.line >= nl) continue;
    use_pose(o.pose);
    double* PQ = line_params + 6 * o.line;
    ceres::CostFunction* cost;
    ceres::LossFunction* loss;
    if (observed_lines)
      cost = o.stereo ? static_cast<ceres::CostFunction*>(new StereoEndpointLineCost(
                            camera, o.s, o.e, o.s_right, o.e_right, o.sqrt_info))
                      : new MonoEndpointLineCost(camera, o.s, o.e, o.s, o.e, o.sqrt_info);
    else if (o.stereo)
      cost = new StereoLineCost(camera, LineThrough(o.s, o.e), LineThrough(o.s_right, o.e_right),
                                o.sqrt_info);
    else
      cost = new MonoLineCost(camera, LineThrough(o.s, o.e), LineThrough(o.s, o.e), o.sqrt_info);
    loss = new ceres::HuberLoss(o.stereo ? huber_line_stereo : huber_line_mono);
    line_blocks[k] = ceres_problem.AddResidualBlock(cost, loss, pose_params[o.pose].data(), PQ);
    if (!ordering->IsMember(PQ)) {
      ordering->AddElementToGroup(PQ, 0);
      if (options.line_extent_weight > 0.0)  // holds the endpoints' slide along the line
        ceres_problem.AddResidualBlock(
            new LineExtentCost(p.line_P[o.line], p.line_Q[o.line], options.line_extent_weight),
            nullptr, PQ);
    }
  }
  // The gauge: fixed poses, or the first used pose when the caller fixed none.
  for (int i = 0; i < np; ++i) {
    if (!pose_used[i]) continue;
    if (p.poses[i].fixed || !any_fixed) {
      ceres_problem.SetParameterBlockConstant(pose_params[i].data());
      any_fixed = true;
    }
  }
  if (ceres_problem.NumResidualBlocks() == 0) {
    summary.message = "no observations";
    return summary;
  }

  ceres::Solver::Options solver;
  solver.linear_solver_type = options.schur == "dense" ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  solver.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver.linear_solver_ordering = ordering;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = options.num_threads;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  AbortCallback abort_callback(abort);
  if (abort) solver.callbacks.push_back(&abort_callback);

  std::vector<uint8_t> disparity_outlier(p.point_obs.size(), 0);
  // Flags the observations still in the problem; removed ones keep their flag.
  auto flag_outliers = [&]() {
    for (size_t k = 0; k < p.point_obs.size(); ++k) {
      if (!point_blocks[k]) continue;
      const BaPointObservation& o = p.point_obs[k];
      const SE3 T_c_w = SE3FromParams(pose_params[o.pose].data());
      const Eigen::Map<const Eigen::Vector3d> p_w(point_params + 3 * o.point);
      BaPointObservation left = o;
      // A split observation: the left image decides, the disparity has its own gate.
      left.stereo = o.stereo && !split_disparity;
      const Evaluation ev = EvaluatePoint(camera, T_c_w, p_w, left);
      const double chi2_max =
          (left.stereo ? options.point_chi2_stereo : options.point_chi2_mono) * sigma2;
      summary.point_outlier[k] = ev.depth < options.min_depth || ev.chi2 > chi2_max;
      if (disparity_blocks[k]) {
        double e = 0.0;  // whitened by DisparityCost; a point too close is flagged above
        ceres_problem.EvaluateResidualBlock(disparity_blocks[k], false, nullptr, &e, nullptr);
        disparity_outlier[k] = !(e * e <= kChi2OneDof * sigma2);
      }
    }
    for (size_t k = 0; k < p.line_obs.size(); ++k) {
      if (!line_blocks[k]) continue;
      const BaLineObservation& o = p.line_obs[k];
      const Evaluation ev = EvaluateLine(
          camera, SE3FromParams(pose_params[o.pose].data()),
          Eigen::Map<const Eigen::Vector3d>(line_params + 6 * o.line),
          Eigen::Map<const Eigen::Vector3d>(line_params + 6 * o.line + 3), o, observed_lines);
      const double chi2_max =
          (o.stereo ? options.line_chi2_stereo : options.line_chi2_mono) * sigma2;
      summary.line_outlier[k] = ev.depth < options.min_depth || ev.chi2 > chi2_max;
    }
    summary.point_outliers =
        static_cast<int>(std::count(summary.point_outlier.begin(), summary.point_outlier.end(), 1));
    summary.line_outliers =
        static_cast<int>(std::count(summary.line_outlier.begin(), summary.line_outlier.end(), 1));
  };

  ceres::Solver::Summary first;
  ceres::Solve(solver, &ceres_problem, &first);
  summary.initial_cost = first.initial_cost;
  summary.final_cost = first.final_cost;
  summary.iterations = static_cast<int>(first.iterations.size());
  summary.success = first.IsSolutionUsable();
  if (!summary.success)
    summary.message = abort && abort->load() ? std::string("aborted") : first.message;
  flag_outliers();
  const int disparity_outliers =
      static_cast<int>(std::count(disparity_outlier.begin(), disparity_outlier.end(), 1));
  if (summary.success && options.second_pass &&
      summary.point_outliers + summary.line_outliers + disparity_outliers > 0) {
    // A free pose left with fewer inlier observations than it takes to fix a pose went where its
    // own observations do not fit (pulled by a wrong one, or by landmarks the others moved): it
    // goes back to where it started and is held there.
    constexpr int kMinPoseInliers = 3;
    std::vector<int> pose_inliers(np, 0);
    for (size_t k = 0; k < p.point_obs.size(); ++k)
      if (point_blocks[k] && !summary.point_outlier[k]) ++pose_inliers[p.point_obs[k].pose];
    for (size_t k = 0; k < p.line_obs.size(); ++k)
      if (line_blocks[k] && !summary.line_outlier[k]) ++pose_inliers[p.line_obs[k].pose];
    for (int i = 0; i < np; ++i) {
      if (!pose_used[i] || ceres_problem.IsParameterBlockConstant(pose_params[i].data()) ||
          pose_inliers[i] >= kMinPoseInliers)
        continue;
      SE3ToParams(p.poses[i].T_w_c.inverse(), pose_params[i].data());
      ceres_problem.SetParameterBlockConstant(pose_params[i].data());
    }
    for (size_t k = 0; k < point_blocks.size(); ++k) {
      if (point_blocks[k] && summary.point_outlier[k]) {
        ceres_problem.RemoveResidualBlock(point_blocks[k]);
        point_blocks[k] = nullptr;
      }
      if (disparity_blocks[k] && (summary.point_outlier[k] || disparity_outlier[k])) {
        ceres_problem.RemoveResidualBlock(disparity_blocks[k]);
        disparity_blocks[k] = nullptr;
      }
    }
    for (size_t k = 0; k < line_blocks.size(); ++k)
      if (line_blocks[k] && summary.line_outlier[k]) {
        ceres_problem.RemoveResidualBlock(line_blocks[k]);
        line_blocks[k] = nullptr;
      }
    ceres::Solver::Summary second;
    ceres::Solve(solver, &ceres_problem, &second);
    summary.final_cost = second.final_cost;
    summary.iterations += static_cast<int>(second.iterations.size());
    summary.success = second.IsSolutionUsable();
    if (!summary.success)
      summary.message = abort && abort->load() ? std::string("aborted") : second.message;
    flag_outliers();
  }
  if (summary.success) {
    for (int i = 0; i < npt; ++i)
      p.points[i] = Eigen::Map<const Eigen::Vector3d>(point_params + 3 * i);
    for (int i = 0; i < nl; ++i) {
      p.line_P[i] = Eigen::Map<const Eigen::Vector3d>(line_params + 6 * i);
      p.line_Q[i] = Eigen::Map<const Eigen::Vector3d>(line_params + 6 * i + 3);
    }
  }
  if (summary.success)
    for (int i = 0; i < np; ++i)
      if (pose_used[i] && !p.poses[i].fixed)
        p.poses[i].T_w_c = SE3FromParams(pose_params[i].data()).inverse();
  summary.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace pl_slam
