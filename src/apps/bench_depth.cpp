// pl_slam_bench_depth: signed disparity error (bias) of the tracker's stereo features against
// ground truth, per feature type and depth bin (issue 24, "depth without bias"). Not a test:
// it prints Markdown tables for the record.
//
//   --street LAYOUT[,LAYOUT] [--seeds 1,2,3] [--frames N]: synthetic streets (KITTI-like car
//       camera); ground truth by casting rays into the world at each feature's exact position
//   --gt DIR: stereo_disparity_gt (KITTI 2015 000046_10, LiDAR-based disparity map)
//
// Features are detected and stereo-matched exactly as the tracker does (PointDetector +
// MatchStereoPoints with sub-pixel refinement, LineDetector + MatchStereoLines, the tracker's
// options, --set overrides them). Errors are measured - true disparity (px); a positive error makes
// depth too small.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "depth_bias.h"
#include "pl_slam/features/line_features.h"
#include "pl_slam/features/point_features.h"
#include "pl_slam/matching/line_matching.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/sim/street_scenes.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/option_table.h"

namespace {

namespace fs = std::filesystem;
using pl_slam::bench::BiasTable;
using pl_slam::bench::DisparitySample;

constexpr char kUsage[] =
    "usage: pl_slam_bench_depth (--street LAYOUT[,LAYOUT] | --gt DIR) [options]\n"
    "  --street LAYOUTS    street_straight, street_curve, street_junction, ... (comma list)\n"
    "  --seeds 1,2,3       world seeds of the street layouts (default 1)\n"
    "  --frames N          frames per drive, evenly spread over it (default 20)\n"
    "  --gt DIR            stereo_disparity_gt folder (KITTI_2015/training/..._10 pair)\n"
    "  --no-subpixel       points: coarse (keypoint) disparities, for comparison\n"
    "  --csv FILE          every scored feature: type,z_gt,d_gt,d_meas,u,v,angle_deg\n"
    "  --set K=V[,K=V...]  tracker option overrides, as pl_slam_offline takes them\n";

// Feature types, one table each.
enum Kind {
  kPointInterior,
  kPointBoundary,
  kEndpointSteep,
  kEndpointShallow,
  kEndpointJunction,
  kEndpointOneJunction,
  kKinds
};
const char* const kKindNames[kKinds] = {
    "points, one surface within the 11x11 refinement patch",
    "points near an occlusion boundary (GT: the surface within 1.5 px closest to the measurement)",
    "line endpoints, steep segments (> 45 deg from the rows)",
    "line endpoints, shallow segments (15-45 deg from the rows)",
    "line endpoints, flat segments (< 15 deg from the rows: depth from their L junctions)",
    "line endpoints, flat segments with one L junction (tracker.line_matching.junction_one_end)"};

// Ground truth seen from one left image: the true (geometric) disparity at a sub-pixel
// position of each surface seen at or near it.
class GroundTruth {
 public:
  virtual ~GroundTruth() = default;
  // Disparities at (u, v) of the surfaces seen at (u, v) and at (u, v) +- r * dir for each
  // direction, the nearest (largest) first; more than one = (u, v) is at an occlusion
  // boundary. False when none is known.
  virtual bool Disparity(const Eigen::Vector2d& uv, const std::vector<Eigen::Vector2d>& dirs,
                         double r, std::vector<double>* d) const = 0;
};

// Synthetic world: rays through the exact positions; the foreground surface's plane is
// evaluated at (u, v) itself, so the value is exact even when (u, v) is a hair off it.
class WorldGroundTruth : public GroundTruth {
 public:
  WorldGroundTruth(const pl_slam::sim::World& world, const pl_slam::StereoCamera& cam,
                   const pl_slam::SE3& T_w_c)
      : world_(world), cam_(cam), R_(T_w_c.rotation()), c_(T_w_c.translation()) {}

  bool Disparity(const Eigen::Vector2d& uv, const std::vector<Eigen::Vector2d>& dirs, double r,
                 std::vector<double>* d) const override {
    const Eigen::Vector3d ray = R_ * Dir(uv);
    std::vector<int> quads;
    bool miss = false;
    auto cast = [&](const Eigen::Vector2d& p) {
      const pl_slam::sim::RayHit h = world_.RayCast(c_, R_ * Dir(p));
      if (!h.hit) {
        miss = true;
      } else if (std::find(quads.begin(), quads.end(), h.quad) == quads.end()) {
        quads.push_back(h.quad);
      }
    };
    cast(uv);
    for (const auto& dir : dirs) {
      cast(uv + r * dir);
      cast(uv - r * dir);
    }
    std::vector<double> z;
    for (int q : quads) {
      const auto& quad = world_.quads()[q];
      const Eigen::Vector3d n = quad.normal();
      const double zq = n.dot(quad.origin - c_) / n.dot(ray);  // ray has camera z = 1
      if (zq > 0.05 && std::isfinite(zq)) z.push_back(zq);
    }
    std::sort(z.begin(), z.end());
    d->clear();
    // Another plane through the point (a crease, a texture edge on adjoining quads) is not an
    // occlusion: only a depth step of more than 1% is.
    for (double zq : z) {
      if (d->empty() || zq > 1.01 * (cam_.fx * cam_.baseline / d->back())) {
        d->push_back(cam_.fx * cam_.baseline / zq);
      }
    }
    if (miss && d->size() == 1) d->push_back(0.0);  // the sky: no disparity, but a boundary
    return !d->empty();
  }

 private:
  Eigen::Vector3d Dir(const Eigen::Vector2d& p) const {
    return {(p.x() - cam_.cx) / cam_.fx, (p.y() - cam_.cy) / cam_.fy, 1.0};
  }
  const pl_slam::sim::World& world_;
  const pl_slam::StereoCamera& cam_;
  Eigen::Matrix3d R_;
  Eigen::Vector3d c_;
};

// A disparity map (px, <= 0 = unknown): bilinear on one surface (all four neighbours known
// and within 1 px of each other), else the largest (nearest) value among the pixels at and
// around (u, v).
class MapGroundTruth : public GroundTruth {
 public:
  explicit MapGroundTruth(const cv::Mat& disp) : disp_(disp) {}

  bool Disparity(const Eigen::Vector2d& uv, const std::vector<Eigen::Vector2d>& dirs, double r,
                 std::vector<double>* d) const override {
    std::vector<float> seen;
    float lo = INFINITY, hi = -INFINITY;
    int unknown = 0;
    auto take = [&](const Eigen::Vector2d& p) {
      const int x = cvRound(p.x()), y = cvRound(p.y());
      const float g =
          x >= 0 && y >= 0 && x < disp_.cols && y < disp_.rows ? disp_.at<float>(y, x) : 0.0f;
      if (!(g > 0)) {
        ++unknown;
        return;
      }
      lo = std::min(lo, g);
      hi = std::max(hi, g);
      seen.push_back(g);
    };
    take(uv);
    for (const auto& dir : dirs) {
      take(uv + r * dir);
      take(uv - r * dir);
    }
    if (!(hi > 0)) return false;
    d->clear();
    const int x0 = static_cast<int>(std::floor(uv.x())), y0 = static_cast<int>(std::floor(uv.y()));
    if (hi - lo <= 1.0 && x0 >= 0 && y0 >= 0 && x0 + 1 < disp_.cols && y0 + 1 < disp_.rows) {
      const float a = disp_.at<float>(y0, x0), b = disp_.at<float>(y0, x0 + 1),
                  c = disp_.at<float>(y0 + 1, x0), e = disp_.at<float>(y0 + 1, x0 + 1);
      if (a > 0 && b > 0 && c > 0 && e > 0 &&
          std::max({a, b, c, e}) - std::min({a, b, c, e}) <= 1.0f) {
        const double fx = uv.x() - x0, fy = uv.y() - y0;
        d->push_back((1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * e));
        return true;
      }
    }
    // Several surfaces (or no bilinear neighbourhood): each value more than 1 px from the
    // nearer ones is a surface.
    std::sort(seen.rbegin(), seen.rend());
    for (float g : seen) {
      if (d->empty() || g < d->back() - 1.0) d->push_back(g);
    }
    return true;
  }

 private:
  cv::Mat disp_;
};

struct Tables {
  BiasTable kind[kKinds];
  int points_stereo = 0, points_scored = 0, lines_stereo = 0, lines_scored = 0, frames = 0;
  std::ofstream* csv = nullptr;

  void Add(Kind k, DisparitySample s, const Eigen::Vector2d& uv, double angle_deg) {
    s.u = uv.x();
    s.v = uv.y();
    if (!kind[k].Add(s)) return;
    if (csv) {
      *csv << k << ',' << s.z_gt << ',' << s.d_gt << ',' << s.d_meas << ',' << uv.x() << ','
           << uv.y() << ',' << angle_deg << '\n';
    }
  }
  // Adds another set's samples and counts (not to the CSV: they were written already).
  void Merge(const Tables& o) {
    for (int k = 0; k < kKinds; ++k) {
      for (const auto& s : o.kind[k].all()) kind[k].Add(s);
    }
    points_stereo += o.points_stereo;
    points_scored += o.points_scored;
    lines_stereo += o.lines_stereo;
    lines_scored += o.lines_scored;
    frames += o.frames;
  }
};

// Detects and stereo-matches one pair as the tracker does and scores every feature with depth.
void ScorePair(const pl_slam::StereoCamera& cam, const cv::Mat& left, const cv::Mat& right,
               const GroundTruth& gt, const pl_slam::TrackerOptions& to, double line_tolerance,
               Tables* t) {
  const pl_slam::PointDetector pdet{to.points};
  const pl_slam::LineDetector ldet{to.lines};
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  pdet.Detect(left, &kl, &dl);
  pdet.Detect(right, &kr, &dr);
  pl_slam::PointFeatures points;
  pl_slam::MatchStereoPoints(cam, left, right, kl, dl, kr, dr, to.point_matching, &points);
  pl_slam::LineFeatures ll, lr;
  cv::Mat lld, lrd;
  ldet.Detect(left, &ll, &lld);
  ldet.Detect(right, &lr, &lrd);
  pl_slam::MatchStereoLines(cam, &ll, lld, lr, lrd, to.line_matching, nullptr, left, right);
  ++t->frames;

  const double fb = cam.fx * cam.baseline;
  // Points: the refinement compares 11x11 patches, so a surface step within 5 px (rows,
  // columns, diagonals) puts the point near a boundary.
  const std::vector<Eigen::Vector2d> patch_dirs = {
      {1, 0}, {0, 1}, {std::sqrt(0.5), std::sqrt(0.5)}, {std::sqrt(0.5), -std::sqrt(0.5)}};
  for (const auto& p : points) {
    if (!p.has_depth) continue;
    ++t->points_stereo;
    std::vector<double> patch, near;
    if (!gt.Disparity(p.uv, patch_dirs, 5.0, &patch)) continue;
    // At a boundary a corner can belong to either surface (an occluder's corner, or texture
    // of the background beside the occluding edge): GT is whichever surface seen within
    // 1.5 px agrees best with the measurement, so this row bounds the error from below.
    if (!gt.Disparity(p.uv, patch_dirs, 1.5, &near)) continue;
    const double dm = cam.TrueDisparity(p.disparity);
    double d = 0.0;
    for (double c : near) {
      if (c > 0 && (d == 0.0 || std::abs(c - dm) < std::abs(d - dm))) d = c;
    }
    if (!(d > 0)) continue;
    ++t->points_scored;
    t->Add(patch.size() > 1 ? kPointBoundary : kPointInterior, {dm, d, fb / d}, p.uv, 0.0);
  }
  // Lines: GT disparity sampled along the segment (foreground across +-1.5 px), a line fitted
  // through it and evaluated at the endpoints (exact for a 3D segment).
  for (const auto& l : ll) {
    if (!l.has_depth) continue;
    ++t->lines_stereo;
    const std::vector<Eigen::Vector2d> across = {Eigen::Vector2d(l.l(0), l.l(1))};
    std::vector<std::pair<double, double>> td;
    const int n = std::clamp(static_cast<int>(l.length / 2.0), 9, 40);
    for (int k = 0; k < n; ++k) {
      const double s = 0.05 + 0.9 * k / (n - 1);
      // The foreground: an occluding edge belongs to the occluder.
      std::vector<double> d;
      if (gt.Disparity(l.s + s * (l.e - l.s), across, 1.5, &d) && d[0] > 0) {
        td.emplace_back(s, d[0]);
      }
    }
    double g0 = 0.0, g1 = 0.0;
    if (!pl_slam::bench::FitEndpointDisparities(td, line_tolerance, 5, &g0, &g1)) continue;
    if (!(g0 > 0 && g1 > 0)) continue;
    ++t->lines_scored;
    const Kind k = l.one_junction                     ? kEndpointOneJunction
                   : l.depth_from_junctions           ? kEndpointJunction
                   : pl_slam::bench::IsSteep(l.angle) ? kEndpointSteep
                                                      : kEndpointShallow;
    const double deg = l.angle * 180.0 / M_PI;
    t->Add(k, {cam.TrueDisparity(fb / l.P_c.z()), g0, fb / g0}, l.s, deg);
    t->Add(k, {cam.TrueDisparity(fb / l.Q_c.z()), g1, fb / g1}, l.e, deg);
  }
}

void Print(const std::string& title, const Tables& t) {
  std::printf(
      "## %s\n\n%d frames: %d stereo points, %d scored; %d stereo lines, %d scored "
      "(both endpoints)\n\n",
      title.c_str(), t.frames, t.points_stereo, t.points_scored, t.lines_stereo, t.lines_scored);
  for (int k = 0; k < kKinds; ++k) {
    std::printf("### %s\n\n%s\n", kKindNames[k], t.kind[k].Markdown().c_str());
  }
  std::printf(
      "### median error (px) by the fractional part of the true disparity "
      "(errors within 1 px of the median)\n\n"
      "| feature | [0, .25) | [.25, .5) | [.5, .75) | [.75, 1) |\n|---|---|---|---|---|\n");
  for (int k = 0; k < kKinds; ++k) {
    std::printf("| %s |", kKindNames[k]);
    for (const auto& s : pl_slam::bench::ByFraction(t.kind[k].all())) {
      std::printf(s.count ? " %+.3f ± %.3f (%d) |" : " |", s.median, s.median_se, s.count);
    }
    std::printf("\n");
  }
  std::printf("\n");
}

std::string SeedList(const std::vector<int>& seeds) {
  std::string out;
  for (int s : seeds) out += (out.empty() ? "" : ",") + std::to_string(s);
  return out;
}

void RunStreet(const std::vector<std::string>& layouts, const std::vector<int>& seeds, int frames,
               const pl_slam::TrackerOptions& to, std::ofstream* csv) {
  Tables total;
  for (const std::string& layout : layouts) {
    Tables per;
    per.csv = csv;
    for (int seed : seeds) {
      pl_slam::sim::SequenceOptions so =
          pl_slam::sim::DefaultSequenceOptions(pl_slam::sim::ParseSceneKind(layout));
      so.world_seed = static_cast<uint64_t>(seed);
      const pl_slam::sim::SyntheticSequence seq(so);
      const int n = static_cast<int>(seq.size());
      const int m = std::min(frames, n);
      for (int i = 0; i < m; ++i) {
        const int k = m > 1 ? static_cast<int>(std::lround(i * (n - 1.0) / (m - 1))) : 0;
        const pl_slam::StereoFrame f = seq.Render(k);
        const WorldGroundTruth gt(seq.world(), seq.camera(), seq.ground_truth()[k].T_w_c);
        // Exact GT: a sample more than 0.05 px off the line is on another surface.
        ScorePair(seq.camera(), f.left, f.right, gt, to, 0.05, &per);
      }
      std::cerr << layout << " seed " << seed << ": " << m << " frames\n";
    }
    Print(layout + ", world seeds " + SeedList(seeds), per);
    total.Merge(per);
  }
  if (layouts.size() > 1) Print("street scenes, all layouts", total);
}

void RunGt(const fs::path& root, const pl_slam::TrackerOptions& to, std::ofstream* csv) {
  const fs::path kitti = root / "KITTI_2015" / "training";
  if (!fs::exists(kitti / "image_2" / "000046_10.png")) {
    throw pl_slam::InputError((kitti / "image_2" / "000046_10.png").string() + ": not found");
  }
  const cv::Mat l =
      cv::imread((kitti / "image_2" / "000046_10.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat r =
      cv::imread((kitti / "image_3" / "000046_10.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat raw =
      cv::imread((kitti / "disp_occ_0" / "000046_10.png").string(), cv::IMREAD_UNCHANGED);
  if (l.empty() || r.empty() || raw.type() != CV_16UC1) {
    throw pl_slam::InputError(kitti.string() + ": cannot read the 000046_10 pair and its GT");
  }
  cv::Mat gt;
  raw.convertTo(gt, CV_32F, 1.0 / 256.0);
  // KITTI's colour pair (P2, P3 of the 2011_09_26 drives): fx 721.5377 px, baseline 0.5327 m.
  pl_slam::StereoCamera cam;
  cam.fx = cam.fy = 721.5377;
  cam.cx = 609.5593;
  cam.cy = 172.854;
  cam.baseline = 0.5327;
  cam.width = l.cols;
  cam.height = l.rows;
  Tables t;
  t.csv = csv;
  // The GT is a LiDAR map resampled to pixels (+-0.3 px and worse at edges): a line sample
  // more than 0.5 px off the fit is taken as another surface.
  ScorePair(cam, l, r, MapGroundTruth(gt), to, 0.5, &t);
  Print("KITTI 2015 000046_10 (disp_occ_0)", t);

  // Reference: an independent matcher (OpenCV semi-global block matching, its own sub-pixel
  // fit) on every GT pixel. An error all matchers share is in the data (the GT or the image
  // pair), not in the tracker's matching.
  cv::Mat sgbm_raw, sgbm;
  cv::StereoSGBM::create(0, 256, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 2,
                         cv::StereoSGBM::MODE_SGBM_3WAY)
      ->compute(l, r, sgbm_raw);
  sgbm_raw.convertTo(sgbm, CV_32F, 1.0 / 16.0);
  BiasTable ref;
  for (int v = 0; v < gt.rows; ++v) {
    for (int u = 0; u < gt.cols; ++u) {
      const float g = gt.at<float>(v, u), m = sgbm.at<float>(v, u);
      if (g > 0 && m > 0) ref.Add({m, g, cam.fx * cam.baseline / g});
    }
  }
  std::printf("### reference: OpenCV StereoSGBM (block 5, 3-way) at every GT pixel\n\n%s\n",
              ref.Markdown().c_str());
  BiasTable at_points;
  for (const DisparitySample& p : t.kind[kPointInterior].all()) {
    const float m = sgbm.at<float>(cvRound(p.v), cvRound(p.u));
    if (m > 0) at_points.Add({m, p.d_gt, p.z_gt});
  }
  std::printf("### reference: StereoSGBM at the pixels of the scored one-surface points\n\n%s\n",
              at_points.Markdown().c_str());
}

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string x; std::getline(ss, x, ',');) {
    if (!x.empty()) out.push_back(x);
  }
  return out;
}

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(argc, argv, {"street", "seeds", "frames", "gt", "csv", "set"},
                                {"no-subpixel", "help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (cl.Has("street") == cl.Has("gt"))
    throw pl_slam::ConfigError("give --street or --gt\n" + std::string(kUsage));
  cv::setNumThreads(1);
  pl_slam::SystemOptions options;
  if (cl.Has("set")) pl_slam::MakeOptionTable(&options).SetAssignments(cl.Get("set", ""));
  const std::string invalid = options.Validate();
  if (!invalid.empty()) throw pl_slam::ConfigError(invalid);
  const bool subpixel = !cl.Has("no-subpixel");
  options.tracker.point_matching.subpixel = subpixel;
  std::ofstream csv;
  if (cl.Has("csv")) {
    csv.open(cl.Get("csv", ""));
    if (!csv) throw pl_slam::InputError(cl.Get("csv", "") + ": cannot write");
    csv << "type,z_gt,d_gt,d_meas,u,v,angle_deg\n";
  }
  std::ofstream* csv_ptr = csv.is_open() ? &csv : nullptr;
  std::printf(
      "Signed disparity error = measured - true (px; > 0: depth too small). Point "
      "sub-pixel refinement %s; %s.\n\n",
      subpixel ? "on" : "off",
      cl.Has("set") ? ("the tracker's options with " + cl.Get("set", "")).c_str()
                    : "the tracker's detector and matcher options");
  if (cl.Has("gt")) {
    RunGt(cl.Get("gt", ""), options.tracker, csv_ptr);
  } else {
    std::vector<int> seeds;
    for (const std::string& s : Split(cl.Get("seeds", "1"))) seeds.push_back(std::stoi(s));
    const int frames = cl.GetInt("frames", 20);
    if (frames < 1) throw pl_slam::ConfigError("--frames must be at least 1");
    RunStreet(Split(cl.Get("street", "")), seeds, frames, options.tracker, csv_ptr);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_bench_depth", [&] { return Run(argc, argv); });
}
