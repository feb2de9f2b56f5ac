// pl_slam_bench_ba: how far a map's bundle adjustment optimum lies from the truth, against
// what the observations' noise alone explains. Not a test: it prints numbers for the record.
//
// The map (pl_slam_offline --save-map) of a sequence with ground truth is solved as one global
// bundle adjustment over every keyframe, started at the truth: keyframe poses set to their
// true poses (expressed in the map's frame through the first keyframe), landmarks fitted with
// the poses held, then every pose but the first freed. The keyframe ATE of that optimum says
// how far the map's own observations pull away from the truth. The same is then done with
// simulated observations: every observation replaced by the exact image of its truth-fitted
// landmark plus Gaussian noise of the size the real ones have at the truth (whitened RMS,
// points and lines apart), several draws. An optimum as far from the truth as the simulated
// ones is what noise of that size explains; one much farther says the observations carry
// something else (bias, wrong associations).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "pl_slam/eval/alignment.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/map/map.h"
#include "pl_slam/map/map_io.h"
#include "pl_slam/optimization/bundle_adjustment.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

#include "../mapping/mapping_steps.h"

namespace {

using pl_slam::SE3;
using Poses = std::vector<SE3, Eigen::aligned_allocator<SE3>>;

constexpr char kUsage[] =
    "usage: pl_slam_bench_ba --data DIR --map FILE [--draws N] [--iterations N] [--seed S]\n"
    "  --data DIR        the sequence the map was made from (EuRoC or KITTI folder with ground\n"
    "                    truth)\n"
    "  --map FILE        map saved by pl_slam_offline --save-map (default options)\n"
    "  --draws N         simulated noise draws (default 3)\n"
    "  --iterations N    Levenberg-Marquardt iterations of each solve (default 20)\n"
    "  --seed S          first noise seed (default 1)\n"
    "  --simulate WHAT   observations replaced by simulated ones: both (default), points\n"
    "                    (lines stay real) or lines (points stay real)\n";

// The whole map as one bundle adjustment problem, built by local mapping's own window
// builder: every keyframe free but the oldest (the gauge), poses in map order. Point
// observations are the detected positions: map files do not keep mapping.align_points'
// offsets.
pl_slam::BaProblem BuildProblem(pl_slam::Map* map, const pl_slam::StereoCamera& cam,
                                const pl_slam::SystemOptions& so) {
  pl_slam::mapping::Context ctx;
  ctx.camera = cam;
  ctx.options = so.mapping;
  ctx.front_end.scale_factor = so.tracker.points.scale_factor;
  ctx.map = map;
  auto lock = map->Lock();
  std::vector<pl_slam::KeyframeId> all;
  for (const auto& [id, kf] : map->KeyframesLocked()) all.push_back(id);
  pl_slam::mapping::BaWindow window;
  if (!pl_slam::mapping::BuildBaWindowLocked(ctx, all, 0, &window))
    throw pl_slam::InputError("the map has under 2 keyframes");
  return window.problem;
}

// Keyframe ATE (RMSE after SE3 alignment), millimetres.
double AteMm(const pl_slam::BaProblem& p, const Poses& truth) {
  pl_slam::eval::Points3d est, gt;
  for (size_t i = 0; i < p.poses.size(); ++i) {
    est.push_back(p.poses[i].T_w_c.translation());
    gt.push_back(truth[i].translation());
  }
  const auto al = pl_slam::eval::UmeyamaAlignment(est, gt, false);
  double sum = 0.0;
  for (size_t i = 0; i < est.size(); ++i) sum += (al.Apply(est[i]) - gt[i]).squaredNorm();
  return 1000.0 * std::sqrt(sum / std::max<size_t>(1, est.size()));
}

// Poses at the truth and held; landmarks fitted to the observations.
void FitLandmarksAtTruth(const pl_slam::StereoCamera& cam,
                         const pl_slam::BundleAdjustmentOptions& ba, const Poses& truth,
                         pl_slam::BaProblem* p) {
  for (size_t i = 0; i < p->poses.size(); ++i) {
    p->poses[i].T_w_c = truth[i];
    p->poses[i].fixed = true;
  }
  pl_slam::SolveBundleAdjustment(cam, ba, p);
}

// Frees every pose but the first and solves; returns the keyframe ATE.
double SolveFromTruth(const pl_slam::StereoCamera& cam, const pl_slam::BundleAdjustmentOptions& ba,
                      const Poses& truth, pl_slam::BaProblem* p) {
  for (size_t i = 1; i < p->poses.size(); ++i) p->poses[i].fixed = false;
  pl_slam::SolveBundleAdjustment(cam, ba, p);
  return AteMm(*p, truth);
}

// Foot of the perpendicular from x to the line through a and b.
Eigen::Vector2d OntoLine(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                         const Eigen::Vector2d& x) {
  const Eigen::Vector2d d = (b - a).normalized();
  return a + d * d.dot(x - a);
}

struct Rms {
  double points = 0.0, lines = 0.0;
};

// Whitened RMS of the observations at the current poses and landmarks (point: pixel
// differences; line: distances of the observed endpoints to the projected segment's line).
Rms MeasureRms(const pl_slam::StereoCamera& cam, const pl_slam::BaProblem& p) {
  double sp = 0.0, sl = 0.0;
  long np = 0, nl = 0;
  for (const auto& o : p.point_obs) {
    const Eigen::Vector3d pc = p.poses[o.pose].T_w_c.inverse() * p.points[o.point];
    if (pc.z() < 0.05) continue;
    const Eigen::Vector2d e = (cam.Project(pc) - o.uv) * o.sqrt_info;
    if (e.norm() > 5.0) continue;  // an outlier, not noise
    sp += e.squaredNorm();
    np += 2;
  }
  for (const auto& o : p.line_obs) {
    const SE3 T_c_w = p.poses[o.pose].T_w_c.inverse();
    const Eigen::Vector3d P = T_c_w * p.line_P[o.line], Q = T_c_w * p.line_Q[o.line];
    if (P.z() < 0.05 || Q.z() < 0.05) continue;
    const Eigen::Vector2d a = cam.Project(P), b = cam.Project(Q);
    if ((b - a).norm() < 1.0) continue;
    const double ds = (OntoLine(a, b, o.s) - o.s).norm() * o.sqrt_info,
                 de = (OntoLine(a, b, o.e) - o.e).norm() * o.sqrt_info;
    if (ds > 5.0 || de > 5.0) continue;
    sl += ds * ds + de * de;
    nl += 2;
  }
  Rms r;
  r.points = np ? std::sqrt(sp / np) : 0.0;
  r.lines = nl ? std::sqrt(sl / nl) : 0.0;
  return r;
}

// Replaces every observation by the exact image of its landmark plus Gaussian noise of
// whitened size `rms` (line endpoints move across the projected line only).
void Simulate(const pl_slam::StereoCamera& cam, const Rms& rms, bool points, bool lines,
              std::mt19937_64* rng, pl_slam::BaProblem* p) {
  std::normal_distribution<double> n(0.0, 1.0);
  for (auto& o : p->point_obs) {
    if (!points) break;
    const Eigen::Vector3d pc = p->poses[o.pose].T_w_c.inverse() * p->points[o.point];
    if (pc.z() < 0.05) continue;
    const double s = rms.points / o.sqrt_info;
    o.uv = cam.Project(pc) + s * Eigen::Vector2d(n(*rng), n(*rng));
    o.u_right = cam.ProjectRight(pc).x() + s * n(*rng);
  }
  for (auto& o : p->line_obs) {
    if (!lines) break;
    const SE3 T_c_w = p->poses[o.pose].T_w_c.inverse();
    const Eigen::Vector3d P = T_c_w * p->line_P[o.line], Q = T_c_w * p->line_Q[o.line];
    if (P.z() < 0.05 || Q.z() < 0.05) continue;
    const double s = rms.lines / o.sqrt_info;
    auto place = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, Eigen::Vector2d* x) {
      if ((b - a).norm() < 1.0) return;
      const Eigen::Vector2d d = (b - a).normalized();
      *x = OntoLine(a, b, *x) + Eigen::Vector2d(-d.y(), d.x()) * s * n(*rng);
    };
    place(cam.Project(P), cam.Project(Q), &o.s);
    place(cam.Project(P), cam.Project(Q), &o.e);
    if (o.stereo) {
      place(cam.ProjectRight(P), cam.ProjectRight(Q), &o.s_right);
      place(cam.ProjectRight(P), cam.ProjectRight(Q), &o.e_right);
    }
  }
}

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv, {"data", "map", "draws", "iterations", "seed", "simulate"}, {"help"});
  if (cl.Has("help") || !cl.Has("data") || !cl.Has("map")) {
    std::fputs(kUsage, cl.Has("help") ? stdout : stderr);
    return cl.Has("help") ? 0 : 2;
  }
  const int draws = cl.GetInt("draws", 3);
  const int iterations = cl.GetInt("iterations", 20);
  const int seed = cl.GetInt("seed", 1);
  const std::string simulate = cl.Get("simulate", "both");
  if (draws < 0 || iterations < 1) throw pl_slam::ConfigError("--draws >= 0, --iterations >= 1");
  if (simulate != "both" && simulate != "points" && simulate != "lines")
    throw pl_slam::ConfigError("--simulate must be both, points or lines, not " + simulate);

  const auto source = pl_slam::OpenDatasetFolder(cl.Get("data", ""));
  const pl_slam::StereoCamera cam = source->camera();
  const pl_slam::Trajectory& gt = source->ground_truth();
  if (gt.empty()) throw pl_slam::InputError(cl.Get("data", "") + ": no ground truth");
  pl_slam::Map map;
  pl_slam::LoadMap(cl.Get("map", ""), &map);
  pl_slam::MapContents m;
  {
    auto lock = map.Lock();
    m = map.ExportLocked();
  }
  if (m.keyframes.size() < 3) throw pl_slam::InputError(cl.Get("map", "") + ": under 3 keyframes");

  // True keyframe poses (nearest ground-truth stamp) in the map's frame.
  Poses truth;
  for (const auto& [id, kf] : m.keyframes) {
    const auto it = std::min_element(gt.begin(), gt.end(), [&](const auto& a, const auto& b) {
      return std::abs(a.t - kf->stamp_s) < std::abs(b.t - kf->stamp_s);
    });
    if (std::abs(it->t - kf->stamp_s) > 1e-3)
      throw pl_slam::InputError("keyframe at " + std::to_string(kf->stamp_s) +
                                " s has no ground-truth pose");
    truth.push_back(it->T_w_c);
  }
  const SE3 T_map_gt = m.keyframes.begin()->second->T_w_c * truth.front().inverse();
  for (SE3& T : truth) T = T_map_gt * T;

  const pl_slam::SystemOptions so;
  pl_slam::BundleAdjustmentOptions ba = so.mapping.ba;
  ba.max_iterations = iterations;

  pl_slam::BaProblem base = BuildProblem(&map, cam, so);
  std::printf("map: %zu keyframes, %zu points (%zu observations), %zu lines (%zu observations)\n",
              base.poses.size(), base.points.size(), base.point_obs.size(), base.line_P.size(),
              base.line_obs.size());
  std::printf("keyframe ATE of the map: %.2f mm\n", AteMm(base, truth));

  FitLandmarksAtTruth(cam, ba, truth, &base);
  const Rms rms = MeasureRms(cam, base);
  std::printf("whitened RMS at the truth: points %.3f px, lines %.3f px\n", rms.points, rms.lines);
  pl_slam::BaProblem real = base;
  std::printf("optimum from the truth, real observations: keyframe ATE %.2f mm\n",
              SolveFromTruth(cam, ba, truth, &real));
  std::vector<double> sim;
  for (int d = 0; d < draws; ++d) {
    pl_slam::BaProblem p = base;
    std::mt19937_64 rng(static_cast<uint64_t>(seed + d));
    Simulate(cam, rms, simulate != "lines", simulate != "points", &rng, &p);
    FitLandmarksAtTruth(cam, ba, truth, &p);
    sim.push_back(SolveFromTruth(cam, ba, truth, &p));
    std::printf("optimum from the truth, simulated %s (seed %d): keyframe ATE %.2f mm\n",
                simulate == "both" ? "observations" : simulate.c_str(), seed + d, sim.back());
  }
  if (!sim.empty()) {
    std::sort(sim.begin(), sim.end());
    std::printf("simulated: median %.2f mm, range %.2f - %.2f mm over %zu draws\n",
                sim[sim.size() / 2], sim.front(), sim.back(), sim.size());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_bench_ba", [&] { return Run(argc, argv); });
}
