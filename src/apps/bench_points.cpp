// pl_slam_bench_points: frame-to-frame point matches scored against the true motion on the
// synthetic scenes. Not a test: it prints numbers for tuning and for the record.
//
// Each pair of consecutive frames is matched as the tracker matches it (detector, stereo and
// guided frame-to-frame matching with the tracker's options), with the true relative pose as
// the prediction. A match is correct when the previous point, at its stereo depth, lands
// within 2 px of the current keypoint under the true motion; otherwise its stereo depth is
// the culprit when the rendered depth at its pixel puts it within 2 px, and the match itself
// (or the corner: a T junction's 3D point moves with the view) when not.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "pl_slam/features/point_features.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/sim/lowtex_scenes.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/option_table.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_bench_points --scene NAME [options]\n"
    "  --scene NAME        a synthetic scene (lowtex_wall, lowtex_corner, street_straight, ...)\n"
    "  --bare              lowtex scenes: the bare variant\n"
    "  --seeds 1,2,3       world and noise seeds, as the family's renders (default 1)\n"
    "  --first N           first frame (default 0)\n"
    "  --last N            last frame (default: the whole sequence)\n"
    "  --step K            pairs (i, i+1) for every K-th i (default 1)\n"
    "  --set K=V[,K=V...]  option overrides as pl_slam_offline takes them (tracker.points.*,\n"
    "                      tracker.point_matching.*, tracker.min_inliers)\n";

constexpr double kCorrectPx = 2.0;

struct Frame {
  pl_slam::PointFeatures points;
  cv::Mat descriptors;
  cv::Mat depth;  // rendered depth of the left image, CV_32FC1
};

struct Counts {
  int pairs = 0, matches = 0, correct = 0, depth_off = 0, wrong = 0;
  void Add(const Counts& o) {
    pairs += o.pairs;
    matches += o.matches;
    correct += o.correct;
    depth_off += o.depth_off;
    wrong += o.wrong;
  }
};

std::vector<int> ParseSeeds(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || v < 0)
      throw pl_slam::ConfigError("--seeds: '" + item + "' is not a seed (0, 1, 2, ...)");
    out.push_back(static_cast<int>(v));
  }
  if (out.empty()) throw pl_slam::ConfigError("--seeds: empty list");
  return out;
}

Frame Load(const pl_slam::sim::SyntheticSequence& seq, const pl_slam::PointDetector& detector,
           const pl_slam::PointMatchingOptions& matching, int index) {
  const pl_slam::StereoFrame f = seq.Render(index);
  std::vector<cv::KeyPoint> left, right;
  cv::Mat right_desc;
  Frame out;
  detector.Detect(f.left, &left, &out.descriptors);
  detector.Detect(f.right, &right, &right_desc);
  pl_slam::MatchStereoPoints(seq.camera(), f.left, f.right, left, out.descriptors, right,
                             right_desc, matching, &out.points);
  out.depth = seq.RenderGroundTruth(index).depth;
  return out;
}

Counts ScorePair(const pl_slam::StereoCamera& camera, const Frame& prev, const Frame& cur,
                 const pl_slam::SE3& T_cur_prev, const pl_slam::TrackerOptions& options) {
  Counts c;
  c.pairs = 1;
  // As the tracker calls it (StereoTracker: search everywhere below 2 x min_inliers).
  const auto matches = pl_slam::MatchPointsPredicted(
      camera, prev.points, prev.descriptors, cur.points, cur.descriptors, options.point_matching,
      T_cur_prev, 2 * options.min_inliers);
  for (const auto& [i, j] : matches) {
    ++c.matches;
    const pl_slam::PointFeature& p = prev.points[i];
    const Eigen::Vector2d uv = cur.points[j].uv;
    const Eigen::Vector3d moved = T_cur_prev * p.p_c;
    if (moved.z() > 0.0 && (camera.Project(moved) - uv).norm() <= kCorrectPx) {
      ++c.correct;
      continue;
    }
    const int u = std::clamp(static_cast<int>(std::lround(p.uv.x())), 0, prev.depth.cols - 1);
    const int v = std::clamp(static_cast<int>(std::lround(p.uv.y())), 0, prev.depth.rows - 1);
    const double z = prev.depth.at<float>(v, u);
    const Eigen::Vector3d true_point =
        T_cur_prev * Eigen::Vector3d((p.uv.x() - camera.cx) / camera.fx * z,
                                     (p.uv.y() - camera.cy) / camera.fy * z, z);
    if (z > 0.0 && true_point.z() > 0.0 && (camera.Project(true_point) - uv).norm() <= kCorrectPx)
      ++c.depth_off;
    else
      ++c.wrong;
  }
  return c;
}

void PrintRow(const std::string& name, const Counts& c) {
  const double n = std::max(1, c.matches);
  std::printf("| %s | %d | %d | %.1f | %d (%.1f%%) | %d (%.1f%%) | %d (%.1f%%) |\n", name.c_str(),
              c.pairs, c.matches, static_cast<double>(c.matches) / std::max(1, c.pairs), c.correct,
              100.0 * c.correct / n, c.depth_off, 100.0 * c.depth_off / n, c.wrong,
              100.0 * c.wrong / n);
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_bench_points", [&]() {
    const pl_slam::CommandLine cl(argc, argv, {"scene", "seeds", "first", "last", "step", "set"},
                                  {"bare", "help"});
    if (cl.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!cl.Has("scene")) throw pl_slam::ConfigError("--scene is required (see --help)");
    const pl_slam::sim::SceneKind kind = pl_slam::sim::ParseSceneKind(cl.Get("scene", ""));
    if (cl.Has("bare") && !pl_slam::sim::IsLowtexScene(kind))
      throw pl_slam::ConfigError("--bare applies to the lowtex_* scenes only");
    const std::vector<int> seeds = ParseSeeds(cl.Get("seeds", "1"));
    const int first = cl.GetInt("first", 0);
    const int step = cl.GetInt("step", 1);
    if (first < 0) throw pl_slam::ConfigError("--first must be >= 0");
    if (step < 1) throw pl_slam::ConfigError("--step must be >= 1");
    pl_slam::SystemOptions options;
    const pl_slam::OptionTable table = pl_slam::MakeOptionTable(&options);
    if (cl.Has("set")) table.SetAssignments(cl.Get("set", ""));
    const std::string invalid = options.Validate();
    if (!invalid.empty()) throw pl_slam::ConfigError(invalid);
    const pl_slam::PointDetector detector(options.tracker.points);

    std::printf(
        "frame-to-frame point matches of %s%s, true motion as the prediction; correct: "
        "within %.0f px of the keypoint at the stereo depth\n\n",
        cl.Get("scene", "").c_str(), cl.Has("bare") ? " (bare)" : "", kCorrectPx);
    std::printf(
        "| seed | frame pairs | matches | per pair | correct | off by the stereo depth | "
        "off at the true depth |\n|---|---|---|---|---|---|---|\n");
    Counts total;
    for (int seed : seeds) {
      pl_slam::sim::SequenceOptions so = pl_slam::sim::DefaultSequenceOptions(kind);
      so.world_seed = static_cast<uint64_t>(seed);
      so.seed = static_cast<uint64_t>(seed);
      so.bare = cl.Has("bare");
      const pl_slam::sim::SyntheticSequence seq(so);
      const int n = static_cast<int>(seq.size());
      const int last = std::min(cl.GetInt("last", n - 1), n - 1);
      if (first >= last) {
        throw pl_slam::ConfigError("--first " + std::to_string(first) +
                                   " must be below the last frame, " + std::to_string(last));
      }
      Counts per;
      Frame cur;
      for (int i = first; i < last; i += step) {
        // With --step 1 the previous pair's current frame is this pair's previous one.
        const Frame prev = step == 1 && i > first
                               ? std::move(cur)
                               : Load(seq, detector, options.tracker.point_matching, i);
        cur = Load(seq, detector, options.tracker.point_matching, i + 1);
        const pl_slam::SE3 T_cur_prev =
            seq.ground_truth()[i + 1].T_w_c.inverse() * seq.ground_truth()[i].T_w_c;
        per.Add(ScorePair(seq.camera(), prev, cur, T_cur_prev, options.tracker));
      }
      PrintRow(std::to_string(seed), per);
      total.Add(per);
    }
    if (seeds.size() > 1) PrintRow("all", total);
    return 0;
  });
}
