// Experiment (not built by catkin): where does the bundle adjustment objective of a finished
// map have its optimum, and how far is the map from it? Runs a synthetic scene sequentially,
// prints the map's keyframe ATE at every global BA and every 40 frames, then bundle-adjusts
// the whole final map (a) from where it is and (b) from the ground truth (keyframes moved to
// the truth, landmarks moved with their first observer), printing the keyframe ATE (SE3 and
// Sim3 scale) after each solve. With --gt-residuals: the landmarks alone are optimised at the
// ground-truth poses and the mean signed residuals per kind, depth and octave are printed; then,
// with the poses still at the truth, small changes of the camera (fx, cx, cy, doffs, k1, a scale of
// the truth's translations, a constant camera rotation) are fitted to the point observations, and
// a self-calibrating BA (poses, points and intrinsics free) runs from the map without truth.
// docs/BENCHMARKS.md, ninth and fourteenth sessions, has what it measured.
//
// Build against a built workspace (from the repository root):
//   g++ -O2 -std=c++17 -DNDEBUG -I include -I src/mapping -I /usr/include/eigen3 \
//     -I /usr/include/opencv4 tools/experiments/ba_floor.cpp -o /tmp/ba_floor \
//     -L.ws/devel/lib -lpl_slam_core -lceres -lglog $(pkg-config --libs opencv4) \
//     -Wl,-rpath,$PWD/.ws/devel/lib
// Run: /tmp/ba_floor room|corridor|fast_turn|DATASET_FOLDER [--loops N] [--no-loop]
//   [--no-followup] [--gt-residuals] [--max-frames N] [--doffs PX] [--outlier-sigma S]
//   [--seed N] (the synthetic scene's image-noise seed, as seed_sweep.py's)
// A dataset folder (EuRoC or KITTI layout, as pl_slam_offline reads) replaces the synthetic
// scene; its ground truth is taken frame by frame. Each solve also prints the error of the
// consecutive keyframes' relative translation along the true motion (mm, + = too long).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <string>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "mapping_steps.h"
#include "pl_slam/eval/alignment.h"
#include "pl_slam/eval/evaluation.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/optimization/line_cost.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"

namespace {

using pl_slam::SE3;
using Poses = std::vector<SE3, Eigen::aligned_allocator<SE3>>;

/// Keyframe ATE (mm) of `T_w_c` against `truth`, SE3-aligned; Sim3 scale and ATE printed.
double KeyframeAte(const Poses& T_w_c, const Poses& truth) {
  pl_slam::eval::Points3d a, b;
  for (size_t i = 0; i < T_w_c.size(); ++i) {
    a.push_back(T_w_c[i].translation());
    b.push_back(truth[i].translation());
  }
  if (a.size() < 3) return 0.0;
  auto rmse = [&](const pl_slam::eval::Alignment& al) {
    double s = 0.0;
    for (size_t i = 0; i < a.size(); ++i) s += (al.Apply(a[i]) - b[i]).squaredNorm();
    return std::sqrt(s / a.size()) * 1000.0;
  };
  const auto sim3 = pl_slam::eval::UmeyamaAlignment(a, b, true);
  std::cout << "[Sim3 scale " << sim3.scale << ", ATE " << rmse(sim3) << " mm] ";
  return rmse(pl_slam::eval::UmeyamaAlignment(a, b, false));
}

/// For consecutive keyframes: estimated minus true relative translation, along the true one.
std::string AlongTravel(const Poses& T_w_c, const Poses& truth) {
  std::string out;
  for (size_t i = 0; i + 1 < T_w_c.size() && i < 12; ++i) {
    const Eigen::Vector3d t_true = (truth[i].inverse() * truth[i + 1]).translation();
    const Eigen::Vector3d t_est = (T_w_c[i].inverse() * T_w_c[i + 1]).translation();
    if (t_true.norm() < 1e-9) continue;
    out += " " + std::to_string(static_cast<int>(
                     std::lround((t_est - t_true).dot(t_true.normalized()) * 1000.0)));
  }
  return out;
}

/// Residuals (left u, v; right u, 0 when not stereo) of camera-frame point `X_c` with the
/// intrinsics perturbed by `k` = {dfx, dcx, dcy, ddoffs, k1} (k1 a radial distortion on
/// normalised coordinates).
template <typename T>
bool PerturbedResiduals(const pl_slam::StereoCamera& cam, const T* k,
                        const Eigen::Matrix<T, 3, 1>& X_c, const Eigen::Vector2d& uv, bool stereo,
                        double u_right, T* r) {
  const T fx = T(cam.fx) + k[0], fy = T(cam.fy) + k[0] * T(cam.fy / cam.fx);
  const T cx = T(cam.cx) + k[1], cy = T(cam.cy) + k[2];
  const T x = X_c.x() / X_c.z(), y = X_c.y() / X_c.z();
  const T d = T(1) + k[4] * (x * x + y * y);
  r[0] = fx * x * d + cx - T(uv.x());
  r[1] = fy * y * d + cy - T(uv.y());
  const T xr = (X_c.x() - T(cam.baseline)) / X_c.z();
  const T dr = T(1) + k[4] * (xr * xr + y * y);
  r[2] = stereo ? fx * xr * dr + cx + T(cam.doffs) + k[3] - T(u_right) : T(0);
  return true;
}

/// PerturbedResiduals of point `X_w` seen from fixed pose `T_c_w`, its translation scaled by
/// `scale`[0] and the camera turned by angle-axis `w`.
struct CalibCost {
  CalibCost(const pl_slam::StereoCamera& cam, const SE3& T_c_w, const Eigen::Vector2d& uv,
            bool stereo, double u_right)
      : cam_(cam), T_c_w_(T_c_w), uv_(uv), stereo_(stereo), u_right_(u_right) {}
  template <typename T>
  bool operator()(const T* k, const T* scale, const T* w, const T* X_w, T* r) const {
    const Eigen::Matrix<T, 3, 1> X(X_w[0], X_w[1], X_w[2]);
    const Eigen::Matrix<T, 3, 1> X_g =
        T_c_w_.rotation().cast<T>() * X + T_c_w_.translation().cast<T>() * scale[0];
    Eigen::Matrix<T, 3, 1> X_c;  // the camera rotated by w against the truth's camera frame
    ceres::AngleAxisRotatePoint(w, X_g.data(), X_c.data());
    return PerturbedResiduals(cam_, k, X_c, uv_, stereo_, u_right_, r);
  }
  pl_slam::StereoCamera cam_;
  SE3 T_c_w_;
  Eigen::Vector2d uv_;
  bool stereo_;
  double u_right_;
};

/// Poses fixed at the truth, landmarks free: which intrinsics / translation scale fit best?
void CalibrateAtTruth(const pl_slam::StereoCamera& cam, const pl_slam::BaProblem& p) {
  struct Variant {
    const char* name;
    bool intrinsics, scale, k1, rotation;
  };
  for (const Variant v : {Variant{"nothing", false, false, false, false},
                          Variant{"translation scale", false, true, false, false},
                          Variant{"camera rotation", false, false, false, true},
                          Variant{"camera rotation + scale", false, true, false, true},
                          Variant{"fx cx cy doffs", true, false, false, false},
                          Variant{"fx cx cy doffs k1", true, false, true, false},
                          Variant{"fx cx cy doffs k1 + scale", true, true, true, false},
                          Variant{"all", true, true, true, true}}) {
    double k[5] = {0, 0, 0, 0, 0}, scale = 1.0, w[3] = {0, 0, 0};
    auto points = p.points;
    ceres::Problem problem;
    int used = 0;
    for (const auto& ob : p.point_obs) {
      const SE3 T_c_w = p.poses[ob.pose].T_w_c.inverse();
      const Eigen::Vector3d X = T_c_w * p.points[ob.point];
      if (X.z() < 0.1 || (cam.Project(X) - ob.uv).norm() > 2.0) continue;
      ++used;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CalibCost, 3, 5, 1, 3, 3>(
                                   new CalibCost(cam, T_c_w, ob.uv, ob.stereo, ob.u_right)),
                               new ceres::HuberLoss(1.0), k, &scale, w, points[ob.point].data());
    }
    if (used == 0) return;
    if (!v.scale) problem.SetParameterBlockConstant(&scale);
    if (!v.rotation) problem.SetParameterBlockConstant(w);
    if (!v.intrinsics) {
      problem.SetParameterBlockConstant(k);
    } else if (!v.k1) {
      problem.SetManifold(k, new ceres::SubsetManifold(5, {4}));
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = 100;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
    std::cout << "calibrate at the truth, " << v.name << ": " << used << " observations, cost "
              << sum.final_cost << "; dfx " << k[0] << " dcx " << k[1] << " dcy " << k[2]
              << " ddoffs " << k[3] << " k1 " << k[4] << " scale " << scale << " rotation (deg) "
              << w[0] * 180 / M_PI << " " << w[1] * 180 / M_PI << " " << w[2] * 180 / M_PI << "\n";
  }
}

/// CalibCost with the pose free too: q (x, y, z, w) and t of T_c_w.
struct SelfCalibCost {
  SelfCalibCost(const pl_slam::StereoCamera& cam, const Eigen::Vector2d& uv, bool stereo,
                double u_right)
      : cam_(cam), uv_(uv), stereo_(stereo), u_right_(u_right) {}
  template <typename T>
  bool operator()(const T* k, const T* q, const T* t, const T* X_w, T* r) const {
    const Eigen::Quaternion<T> Q(q[3], q[0], q[1], q[2]);
    const Eigen::Matrix<T, 3, 1> X_c = Q * Eigen::Matrix<T, 3, 1>(X_w[0], X_w[1], X_w[2]) +
                                       Eigen::Matrix<T, 3, 1>(t[0], t[1], t[2]);
    return PerturbedResiduals(cam_, k, X_c, uv_, stereo_, u_right_, r);
  }
  pl_slam::StereoCamera cam_;
  Eigen::Vector2d uv_;
  bool stereo_;
  double u_right_;
};

/// Poses, landmarks and intrinsics free (points only, first pose fixed): does the map's own
/// data move the intrinsics where the truth wants them?
void SelfCalibrate(const pl_slam::StereoCamera& cam, const pl_slam::BaProblem& p,
                   const Poses& truth, bool with_k1) {
  double k[5] = {0, 0, 0, 0, 0};
  auto points = p.points;
  std::vector<Eigen::Vector4d> q(p.poses.size());
  std::vector<Eigen::Vector3d> t(p.poses.size());
  for (size_t i = 0; i < p.poses.size(); ++i) {
    const SE3 T_c_w = p.poses[i].T_w_c.inverse();
    const Eigen::Quaterniond r(T_c_w.rotation());
    q[i] = Eigen::Vector4d(r.x(), r.y(), r.z(), r.w());
    t[i] = T_c_w.translation();
  }
  ceres::Problem problem;
  for (const auto& ob : p.point_obs) {
    const SE3 T_c_w = p.poses[ob.pose].T_w_c.inverse();
    const Eigen::Vector3d X = T_c_w * p.points[ob.point];
    if (X.z() < 0.1 || (cam.Project(X) - ob.uv).norm() > 2.0) continue;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SelfCalibCost, 3, 5, 4, 3, 3>(
                                 new SelfCalibCost(cam, ob.uv, ob.stereo, ob.u_right)),
                             new ceres::HuberLoss(1.0), k, q[ob.pose].data(), t[ob.pose].data(),
                             points[ob.point].data());
  }
  for (size_t i = 0; i < p.poses.size(); ++i) {
    if (!problem.HasParameterBlock(q[i].data())) continue;
    problem.SetManifold(q[i].data(), new ceres::EigenQuaternionManifold);
    if (i == 0 || p.poses[i].fixed) {
      problem.SetParameterBlockConstant(q[i].data());
      problem.SetParameterBlockConstant(t[i].data());
    }
  }
  if (!with_k1) problem.SetManifold(k, new ceres::SubsetManifold(5, {4}));
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = 100;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  Poses est;
  for (size_t i = 0; i < p.poses.size(); ++i) {
    const Eigen::Quaterniond r(q[i][3], q[i][0], q[i][1], q[i][2]);
    est.push_back(SE3(r.normalized().toRotationMatrix(), t[i]).inverse());
  }
  std::cout << "self-calibrating BA" << (with_k1 ? " with k1" : "") << ": cost " << sum.initial_cost
            << " -> " << sum.final_cost << "; dfx " << k[0] << " dcx " << k[1] << " dcy " << k[2]
            << " ddoffs " << k[3] << " k1 " << k[4] << "; keyframe ATE ";
  std::cout << KeyframeAte(est, truth) << " mm\n";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace pl_slam;
  if (argc < 2) {
    std::cerr << "usage: ba_floor room|corridor|fast_turn [--loops N] [--no-loop] "
                 "[--no-followup] [--gt-residuals]\n";
    return 2;
  }
  sim::SequenceOptions so;
  const std::string scene = argv[1];
  const bool synthetic = scene == "room" || scene == "corridor" || scene == "fast_turn";
  so.scene = scene == "corridor"    ? sim::SceneKind::kCorridor
             : scene == "fast_turn" ? sim::SceneKind::kFastTurn
                                    : sim::SceneKind::kRoom;
  SystemOptions o;
  o.mapping.threaded = false;
  o.loop.vocabulary = "vocabulary";  // run from the repository root
  bool gt_residuals = false;
  size_t max_frames = 0;
  double doffs = std::nan("");
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--loops") && i + 1 < argc) so.loops = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--seed") && i + 1 < argc) so.seed = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--no-loop")) o.loop.enabled = false;
    if (!std::strcmp(argv[i], "--no-followup")) o.loop.global_ba_followup = 0;
    if (!std::strcmp(argv[i], "--gt-residuals")) gt_residuals = true;
    if (!std::strcmp(argv[i], "--max-frames") && i + 1 < argc) max_frames = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--doffs") && i + 1 < argc) doffs = std::atof(argv[++i]);
    if (!std::strcmp(argv[i], "--outlier-sigma") && i + 1 < argc)
      o.mapping.ba.outlier_sigma = std::atof(argv[++i]);
  }
  std::unique_ptr<StereoSource> source;
  if (synthetic)
    source = std::make_unique<sim::SyntheticSequence>(so);
  else
    source = OpenDatasetFolder(scene);
  StereoCamera camera = source->camera();
  if (!std::isnan(doffs)) camera.doffs = doffs;
  const Trajectory& ground_truth = source->ground_truth();
  if (ground_truth.empty()) {
    std::cerr << "ba_floor: " << scene << " has no ground truth\n";
    return 2;
  }
  Poses truth;  // in the map frame (the first camera's), one per frame
  const SE3 inv0 = ground_truth[0].T_w_c.inverse();
  for (const auto& s : ground_truth) truth.push_back(inv0 * s.T_w_c);
  const size_t frames =
      max_frames > 0 ? std::min(max_frames, ground_truth.size()) : ground_truth.size();

  SlamSystem system(camera, o);
  auto map_ate = [&] {
    const MapSnapshot snap = system.map().Snapshot();
    Poses est, gt;
    for (const auto& k : snap.keyframes) {
      est.push_back(k.T_w_c);
      gt.push_back(truth[k.frame_index]);
    }
    return KeyframeAte(est, gt);
  };
  int global_bas = 0;
  StereoFrame frame;
  for (size_t i = 0; i < frames && source->Next(&frame); ++i) {
    system.Process(frame);
    if (system.mapping_stats().global_bas != global_bas || i % 40 == 0) {
      global_bas = system.mapping_stats().global_bas;
      std::cout << "frame " << i << ", global BAs " << global_bas << ": keyframe ATE ";
      std::cout << map_ate() << " mm\n";
    }
  }
  system.Flush();
  std::vector<double> times;
  Trajectory used(ground_truth.begin(), ground_truth.begin() + frames);
  for (const auto& s : used) times.push_back(s.t);
  std::cout << "frame ATE "
            << eval::EvaluateTrajectory(system.trajectory(), used, times).ate.translation.rmse *
                   1000.0
            << " mm\n";

  Map& map = const_cast<Map&>(system.map());  // the system is done with it
  mapping::Context ctx;
  ctx.camera = camera;
  ctx.options = o.mapping;
  ctx.options.ba.max_iterations = 30;
  ctx.map = &map;
  for (const bool from_truth : {false, true}) {
    mapping::GlobalBa job;
    if (!mapping::PrepareGlobalBundleAdjustment(ctx, &job)) return 1;
    BaProblem& p = job.window.problem;
    Poses gt;
    {
      auto lock = map.Lock();
      for (KeyframeId id : job.window.pose_ids)
        gt.push_back(truth[map.KeyframeLocked(id)->frame_index]);
    }
    if (from_truth || gt_residuals) {
      Poses correction;
      for (size_t i = 0; i < p.poses.size(); ++i) {
        correction.push_back(gt[i] * p.poses[i].T_w_c.inverse());
        p.poses[i].T_w_c = gt[i];
        p.poses[i].fixed = gt_residuals || i == 0;
      }
      std::vector<int> first_point(p.points.size(), -1), first_line(p.line_P.size(), -1);
      for (const auto& ob : p.point_obs)
        if (first_point[ob.point] < 0) first_point[ob.point] = ob.pose;
      for (const auto& ob : p.line_obs)
        if (first_line[ob.line] < 0) first_line[ob.line] = ob.pose;
      for (size_t i = 0; i < p.points.size(); ++i)
        if (first_point[i] >= 0) p.points[i] = correction[first_point[i]] * p.points[i];
      for (size_t i = 0; i < p.line_P.size(); ++i)
        if (first_line[i] >= 0) {
          p.line_P[i] = correction[first_line[i]] * p.line_P[i];
          p.line_Q[i] = correction[first_line[i]] * p.line_Q[i];
        }
    }
    const BaSummary s = SolveBundleAdjustment(ctx.camera, ctx.options.ba, &p);
    std::cout << (gt_residuals ? "landmarks only, at the ground truth"
                  : from_truth ? "from the ground truth"
                               : "from the map")
              << ": cost " << s.initial_cost << " -> " << s.final_cost << " in " << s.iterations
              << " iterations; keyframe ATE ";
    Poses est;
    for (const auto& pose : p.poses) est.push_back(pose.T_w_c);
    std::cout << KeyframeAte(est, gt) << " mm\n";
    if (from_truth) {
      Poses before;
      auto lock = map.Lock();
      for (KeyframeId id : job.window.pose_ids) before.push_back(map.KeyframeLocked(id)->T_w_c);
      std::cout << "  along travel, map before:" << AlongTravel(before, gt) << "\n";
    }
    std::cout << "  along travel, after:" << AlongTravel(est, gt) << "\n";
    if (!gt_residuals) continue;
    CalibrateAtTruth(ctx.camera, p);
    {
      mapping::GlobalBa from_map;
      if (!mapping::PrepareGlobalBundleAdjustment(ctx, &from_map)) return 1;
      SelfCalibrate(ctx.camera, from_map.window.problem, gt, false);
      SelfCalibrate(ctx.camera, from_map.window.problem, gt, true);
    }
    // Mean signed residuals at the ground-truth poses (landmarks optimised, |r| < 2 px).
    const StereoCamera& cam = ctx.camera;
    // By depth (in baselines): mean radial residual (projection minus observation, along the
    // direction from the principal point) and mean right-image residual of the stereo ones.
    constexpr int kBins = 5;
    const double edges[kBins + 1] = {0.0, 10.0, 20.0, 40.0, 80.0, 1e9};
    double radial[kBins] = {}, radial2[kBins] = {}, right[kBins] = {};
    int count[kBins] = {}, count_right[kBins] = {};
    // By pyramid octave (from the observation's weight, PointSqrtInfo): means of u, v, radial
    // and right-image residuals; their sums give the overall means.
    constexpr int kOctaves = 8;
    double ou[kOctaves] = {}, ov[kOctaves] = {}, orad[kOctaves] = {}, oright[kOctaves] = {};
    int on[kOctaves] = {}, onr[kOctaves] = {};
    for (const auto& ob : p.point_obs) {
      const Eigen::Vector3d X = p.poses[ob.pose].T_w_c.inverse() * p.points[ob.point];
      if (X.z() < 0.1) continue;
      const Eigen::Vector2d e = cam.Project(X) - ob.uv;
      if (e.norm() > 2.0) continue;
      const double u_right_error = ob.stereo ? cam.ProjectRight(X).x() - ob.u_right : 0.0;
      const int o = std::clamp(static_cast<int>(std::lround(-std::log(ob.sqrt_info) /
                                                            std::log(ctx.front_end.scale_factor))),
                               0, kOctaves - 1);
      ou[o] += e.x();
      ov[o] += e.y();
      ++on[o];
      if (ob.stereo) {
        oright[o] += u_right_error;
        ++onr[o];
      }
      const Eigen::Vector2d from_centre = ob.uv - Eigen::Vector2d(cam.cx, cam.cy);
      if (from_centre.norm() < 1.0) continue;
      const double z = X.z() / cam.baseline;
      int bin = 0;
      while (bin + 1 < kBins && z >= edges[bin + 1]) ++bin;
      const double r = e.dot(from_centre.normalized());
      orad[o] += r;
      radial[bin] += r;
      radial2[bin] += r * r;
      ++count[bin];
      if (ob.stereo) {
        right[bin] += u_right_error;
        ++count_right[bin];
      }
    }
    double du = 0, dv = 0, dr = 0;
    int n = 0, nr = 0;
    for (int o = 0; o < kOctaves; ++o) {
      du += ou[o];
      dv += ov[o];
      dr += oright[o];
      n += on[o];
      nr += onr[o];
      if (on[o] > 0)
        std::cout << "points octave " << o << ": " << on[o] << ", mean du " << ou[o] / on[o]
                  << " dv " << ov[o] / on[o] << " radial " << orad[o] / on[o] << "; stereo "
                  << onr[o] << ", mean right du " << oright[o] / std::max(onr[o], 1) << "\n";
    }
    for (int bin = 0; bin < kBins; ++bin) {
      const int c = std::max(count[bin], 1);
      const double mean = radial[bin] / c;
      const double sd = std::sqrt(std::max(0.0, radial2[bin] / c - mean * mean));
      std::cout << "points " << edges[bin] << "-" << edges[bin + 1] << " baselines: " << count[bin]
                << ", mean radial " << mean << " +- " << sd / std::sqrt(c)
                << " (standard error); stereo " << count_right[bin] << ", mean right "
                << right[bin] / std::max(count_right[bin], 1) << "\n";
    }
    std::cout << "points: " << n << " observations, mean du " << du / n << " dv " << dv / n
              << "; right image " << nr << ", mean du " << dr / std::max(nr, 1) << "\n";
    const Eigen::Vector3d centre(cam.cx, cam.cy, 1.0);
    for (int bin = 1; bin < 4; ++bin) {  // line angle from the horizontal, 22.5-degree bins
      double sl = 0, sr = 0;
      int nl = 0, nrl = 0;
      for (const auto& ob : p.line_obs) {
        const Eigen::Vector3d l = LineThrough(ob.s, ob.e);
        const Eigen::Vector3d l_right = LineThrough(ob.s_right, ob.e_right);
        const double angle = std::atan2(std::abs(l.x()), std::abs(l.y())) * 180 / M_PI;
        if (std::min(3, static_cast<int>(angle / 22.5)) != bin) continue;
        const SE3 T_c_w = p.poses[ob.pose].T_w_c.inverse();
        for (const Eigen::Vector3d& X : {T_c_w * p.line_P[ob.line], T_c_w * p.line_Q[ob.line]}) {
          if (X.z() < 0.1) continue;
          // Signed toward the image centre.
          const Eigen::Vector2d u = cam.Project(X);
          const double d = l.dot(Eigen::Vector3d(u.x(), u.y(), 1.0));
          if (std::abs(d) < 2.0) {
            sl += l.dot(centre) > 0 ? d : -d;
            ++nl;
          }
          if (!ob.stereo) continue;
          const Eigen::Vector2d ur = cam.ProjectRight(X);
          const double d_r = l_right.dot(Eigen::Vector3d(ur.x(), ur.y(), 1.0));
          if (std::abs(d_r) < 2.0) {
            sr += l_right.dot(centre) > 0 ? d_r : -d_r;
            ++nrl;
          }
        }
      }
      std::cout << "lines " << bin * 22.5 << "-" << (bin + 1) * 22.5 << " deg: left " << nl
                << ", mean " << sl / std::max(nl, 1) << "; right " << nrl << ", mean "
                << sr / std::max(nrl, 1) << "\n";
    }
    break;
  }
  return 0;
}
