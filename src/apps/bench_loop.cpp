// pl_slam_bench_loop: timing of the loop detector's building blocks. Not a test: it prints
// numbers for the record (docs/BENCHMARKS.md).
//
//  - vocabulary load time (both files), repeated;
//  - BoW transform time per frame (ORB + LBD, ComputeKeyframeBow) on synthetic frames;
//  - database query time with N keyframes: the keyframes are synthetic frames of the room
//    and corridor scenes, each used several times with a different perturbation (a random
//    20 % of its features dropped, 8 random bits of every descriptor flipped), queried with
//    fresh perturbations of the same frames (top-1 recall printed as a sanity check);
//  - relative-pose estimation time between neighbouring synthetic frames.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <random>
#include <sstream>

#include "pl_slam/loop/keyframe_database.h"
#include "pl_slam/loop/loop_features.h"
#include "pl_slam/loop/relative_pose.h"
#include "pl_slam/loop/vocabulary.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

using Clock = std::chrono::steady_clock;

constexpr char kUsage[] =
    "usage: pl_slam_bench_loop [--vocabulary DIR] [--keyframes N] [--queries N]\n"
    "                          [--frames-per-scene N] [--seed S]\n"
    "  --vocabulary DIR       folder with orb.plvoc and lbd.plvoc (default vocabulary)\n"
    "  --keyframes N          keyframes in the database (default 1000)\n"
    "  --queries N            timed queries (default 200)\n"
    "  --frames-per-scene N   distinct synthetic frames per scene (default 40)\n"
    "  --seed S               perturbation seed (default 1)\n";

double Ms(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// "median (p5-p95, IQR x)" of a sample.
std::string Stats(std::vector<double> v) {
  if (v.empty()) return "n/a";
  std::sort(v.begin(), v.end());
  auto q = [&v](double p) {
    return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
  };
  std::ostringstream os;
  os.precision(3);
  os << std::fixed << "median " << q(0.5) << " ms, p5 " << q(0.05) << ", p95 " << q(0.95)
     << ", IQR " << q(0.75) - q(0.25) << " (n=" << v.size() << ")";
  return os.str();
}

// Drops a random share of the features and flips `bits` random bits of every descriptor.
pl_slam::StereoFeatures Perturb(const pl_slam::StereoFeatures& f, double drop, int bits,
                                std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> bit(0, 255);
  pl_slam::StereoFeatures out;
  std::vector<int> keep_p, keep_l;
  for (std::size_t i = 0; i < f.points.size(); ++i)
    if (u(*rng) >= drop) keep_p.push_back(static_cast<int>(i));
  for (std::size_t i = 0; i < f.lines.size(); ++i)
    if (u(*rng) >= drop) keep_l.push_back(static_cast<int>(i));
  auto copy_rows = [&](const cv::Mat& src, const std::vector<int>& rows) {
    cv::Mat dst(static_cast<int>(rows.size()), 32, CV_8UC1);
    for (std::size_t r = 0; r < rows.size(); ++r) {
      src.row(rows[r]).copyTo(dst.row(static_cast<int>(r)));
      for (int b = 0; b < bits; ++b) {
        const int k = bit(*rng);
        dst.at<uint8_t>(static_cast<int>(r), k / 8) ^= static_cast<uint8_t>(1u << (k % 8));
      }
    }
    return dst;
  };
  for (int i : keep_p) out.points.push_back(f.points[i]);
  for (int i : keep_l) out.lines.push_back(f.lines[i]);
  out.point_descriptors = copy_rows(f.point_descriptors, keep_p);
  out.line_descriptors = copy_rows(f.line_descriptors, keep_l);
  return out;
}

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv, {"vocabulary", "keyframes", "queries", "frames-per-scene", "seed"}, {"help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  const std::string voc_dir = cl.Get("vocabulary", "vocabulary");
  const int num_keyframes = cl.GetInt("keyframes", 1000);
  const int num_queries = cl.GetInt("queries", 200);
  const int per_scene = cl.GetInt("frames-per-scene", 40);
  std::mt19937_64 rng(static_cast<uint64_t>(cl.GetInt("seed", 1)));
  if (num_keyframes < 1 || num_queries < 1 || per_scene < 2) {
    throw pl_slam::ConfigError("--keyframes, --queries must be >= 1, --frames-per-scene >= 2");
  }

  // 1. Vocabulary load time.
  std::vector<double> load_ms;
  pl_slam::PointLineVocabulary voc;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = Clock::now();
    voc = pl_slam::PointLineVocabulary::LoadFolder(voc_dir);
    load_ms.push_back(Ms(t0));
  }
  std::cout << voc.points.Describe() << "\n" << voc.lines.Describe() << "\n";
  std::cout << "load (both files):     " << Stats(load_ms) << "\n";

  // 2. Features of synthetic frames (world seed 7, the test scenes; the default vocabulary
  // is trained on other world seeds).
  std::vector<pl_slam::StereoFeatures> base;
  pl_slam::StereoCamera camera;
  std::vector<double> extract_ms;
  for (const auto kind : {pl_slam::sim::SceneKind::kRoom, pl_slam::sim::SceneKind::kCorridor}) {
    pl_slam::sim::SequenceOptions so;
    so.scene = kind;
    const pl_slam::sim::SyntheticSequence seq(so);
    camera = seq.camera();
    pl_slam::LoopFeatureExtractor extractor(seq.camera());
    const int stride = std::max(1, static_cast<int>(seq.size()) / per_scene);
    for (int i = 0; i < per_scene; ++i) {
      const pl_slam::StereoFrame frame = seq.Render(i * stride);
      const auto t0 = Clock::now();
      base.push_back(extractor.Extract(frame));
      extract_ms.push_back(Ms(t0));
    }
  }
  std::cout << "features (tracker front end, for reference): " << Stats(extract_ms) << "\n";

  // 3. Transform time per frame.
  const pl_slam::KeyframeDatabaseOptions dbo;
  std::vector<double> transform_ms;
  for (const auto& f : base) {
    const auto t0 = Clock::now();
    const auto bow = pl_slam::ComputeKeyframeBow(f, voc, camera.width, camera.height, dbo);
    transform_ms.push_back(Ms(t0));
  }
  std::cout << "BoW transform / frame: " << Stats(transform_ms) << "  (~" << base[0].points.size()
            << " points + " << base[0].lines.size() << " lines)\n";

  // 4. Database of N perturbed keyframes, then timed queries.
  pl_slam::KeyframeDatabase db(dbo);
  std::vector<int> base_of_keyframe;
  std::vector<double> add_ms;
  for (int id = 0; id < num_keyframes; ++id) {
    const int b = id % static_cast<int>(base.size());
    const auto bow = pl_slam::ComputeKeyframeBow(Perturb(base[b], 0.2, 8, &rng), voc, camera.width,
                                                 camera.height, dbo);
    const auto t0 = Clock::now();
    db.Add(id, bow);
    add_ms.push_back(Ms(t0));
    base_of_keyframe.push_back(b);
  }
  std::cout << "database add:          " << Stats(add_ms) << "\n";
  std::vector<double> query_ms;
  int correct = 0;
  for (int q = 0; q < num_queries; ++q) {
    const int b = q % static_cast<int>(base.size());
    const auto bow = pl_slam::ComputeKeyframeBow(Perturb(base[b], 0.2, 8, &rng), voc, camera.width,
                                                 camera.height, dbo);
    const auto t0 = Clock::now();
    const auto result = db.Query(bow, 10);
    query_ms.push_back(Ms(t0));
    if (!result.empty() && base_of_keyframe[result[0].id] == b) ++correct;
  }
  std::cout << "query (" << db.size() << " keyframes, top 10): " << Stats(query_ms)
            << ", top-1 correct " << correct << "/" << num_queries << "\n";

  // 5. Relative pose between frames of the same scene 1 step apart.
  pl_slam::RelativePoseOptions rpo;
  std::vector<double> pose_ms;
  int ok = 0;
  for (int i = 0; i + 1 < per_scene; ++i) {
    const auto t0 = Clock::now();
    const auto rp = pl_slam::EstimateRelativePose(camera, base[i + 1], base[i], rpo);
    pose_ms.push_back(Ms(t0));
    ok += rp.success ? 1 : 0;
  }
  std::cout << "relative pose (room frames " << std::max(1, 480 / per_scene)
            << " apart): " << Stats(pose_ms) << ", success " << ok << "/" << per_scene - 1 << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_bench_loop", [&] { return Run(argc, argv); });
}
