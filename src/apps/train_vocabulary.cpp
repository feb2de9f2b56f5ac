// pl_slam_train_vocabulary: trains the ORB and LBD bag-of-words vocabularies of the loop
// detector from the tracker's own features and writes <out>/orb.plvoc and <out>/lbd.plvoc.
//
// Training data (any combination):
//   --sim room,corridor,...  synthetic scenes rendered by the package (deterministic: the
//                            same options always give the same vocabulary)
//   --data DIR[,DIR...]      EuRoC ASL or KITTI odometry folders (rectified by the readers)
//   --images DIR[,DIR...]    folders of single images (*.png, *.jpg, *.pgm): detection only,
//                            the same descriptors the tracker computes for its left image
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "pl_slam/features/line_features.h"
#include "pl_slam/features/point_features.h"
#include "pl_slam/io/image_io.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/loop/loop_features.h"
#include "pl_slam/loop/vocabulary.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr char kUsage[] =
    "usage: pl_slam_train_vocabulary --out DIR [data options] [tree options]\n"
    "data (at least one):\n"
    "  --sim SCENES         comma-separated synthetic scenes (room, corridor, fast_turn)\n"
    "  --sim-world-seeds S  comma-separated world seeds, each scene rendered per seed (default "
    "101)\n"
    "  --sim-frames N       frames per synthetic sequence (default: the scene's default)\n"
    "  --sim-noise SIGMA    image noise of the synthetic frames (default 2)\n"
    "  --data DIRS          comma-separated EuRoC / KITTI folders\n"
    "  --images DIRS        comma-separated folders of single images\n"
    "  --stride N           use every N-th frame (default 4)\n"
    "  --max-frames N       frames per sequence or folder at most (default 0 = all)\n"
    "tree:\n"
    "  --k K                branching factor (default 10)\n"
    "  --depth L            levels (default 4)\n"
    "  --line-depth L       levels of the LBD tree (default: --depth)\n"
    "  --iterations N       k-majority iterations per node (default 15)\n"
    "  --seed S             k-means++ seed (default 1)\n";

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::size_t CountRows(const std::vector<cv::Mat>& sets) {
  std::size_t n = 0;
  for (const cv::Mat& m : sets) n += m.rows;
  return n;
}

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv,
      {"out", "sim", "sim-world-seeds", "sim-frames", "sim-noise", "data", "images", "stride",
       "max-frames", "k", "depth", "line-depth", "iterations", "seed"},
      {"help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (!cl.Has("out")) throw pl_slam::ConfigError(std::string("--out is required\n") + kUsage);
  if (!cl.Has("sim") && !cl.Has("data") && !cl.Has("images")) {
    throw pl_slam::ConfigError(std::string("give --sim, --data or --images\n") + kUsage);
  }
  const int stride = cl.GetInt("stride", 4);
  const int max_frames = cl.GetInt("max-frames", 0);
  if (stride < 1) throw pl_slam::ConfigError("--stride must be at least 1");
  const pl_slam::TrackerOptions tracker_options;  // the run-time defaults
  // Tree options first: a bad value fails before minutes of feature extraction.
  pl_slam::VocabularyOptions vo;
  vo.branching = cl.GetInt("k", vo.branching);
  vo.depth = cl.GetInt("depth", vo.depth);
  vo.max_iterations = cl.GetInt("iterations", vo.max_iterations);
  vo.seed = static_cast<uint64_t>(cl.GetInt("seed", 1));
  for (const int depth : {vo.depth, cl.GetInt("line-depth", vo.depth)}) {
    pl_slam::VocabularyOptions check = vo;
    check.depth = depth;
    const std::string err = check.Validate();
    if (!err.empty()) throw pl_slam::ConfigError("vocabulary: " + err);
  }
  std::vector<cv::Mat> orb, lbd;
  const auto t_data = Clock::now();

  // Synthetic scenes, rendered frame by frame (only the frames used).
  for (const std::string& scene : SplitList(cl.Get("sim", ""))) {
    for (const std::string& seed : SplitList(cl.Get("sim-world-seeds", "101"))) {
      pl_slam::sim::SequenceOptions so;
      so.scene = pl_slam::sim::ParseSceneKind(scene);
      so.num_frames = cl.GetInt("sim-frames", 0);
      so.noise_sigma = cl.GetDouble("sim-noise", 2.0);
      so.world_seed = std::stoull(seed);
      so.seed = so.world_seed;
      const pl_slam::sim::SyntheticSequence seq(so);
      pl_slam::LoopFeatureExtractor extractor(seq.camera(), tracker_options);
      int used = 0;
      for (int i = 0; i < static_cast<int>(seq.size()); i += stride) {
        if (max_frames > 0 && used >= max_frames) break;
        const pl_slam::StereoFeatures f = extractor.Extract(seq.Render(i));
        if (!f.point_descriptors.empty()) orb.push_back(f.point_descriptors.clone());
        if (!f.line_descriptors.empty()) lbd.push_back(f.line_descriptors.clone());
        ++used;
      }
      std::cout << "synthetic " << scene << " (world seed " << seed << "): " << used << " frames\n";
    }
  }
  // Dataset folders through the readers (rectified).
  for (const std::string& dir : SplitList(cl.Get("data", ""))) {
    const auto source = pl_slam::OpenDatasetFolder(dir);
    const int used = pl_slam::CollectTrainingDescriptors(source.get(), stride, max_frames,
                                                         tracker_options, &orb, &lbd);
    std::cout << source->Describe() << ": " << used << " frames\n";
  }
  // Single images: the tracker's detectors on each image.
  const pl_slam::PointDetector point_detector(tracker_options.points);
  const pl_slam::LineDetector line_detector(tracker_options.lines);
  for (const std::string& dir : SplitList(cl.Get("images", ""))) {
    if (!fs::is_directory(dir)) throw pl_slam::InputError(dir + ": not a folder");
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm") {
        files.push_back(e.path().string());
      }
    }
    std::sort(files.begin(), files.end());
    int used = 0;
    for (std::size_t i = 0; i < files.size(); i += stride) {
      if (max_frames > 0 && used >= max_frames) break;
      const cv::Mat img = pl_slam::ReadGrayImage(files[i]);
      std::vector<cv::KeyPoint> kp;
      cv::Mat pd, ld;
      pl_slam::LineFeatures lines;
      point_detector.Detect(img, &kp, &pd);
      line_detector.Detect(img, &lines, &ld);
      if (!pd.empty()) orb.push_back(pd);
      if (!ld.empty()) lbd.push_back(ld);
      ++used;
    }
    std::cout << dir << ": " << used << " images\n";
  }
  std::cout << "descriptors: " << CountRows(orb) << " ORB in " << orb.size() << " images, "
            << CountRows(lbd) << " LBD in " << lbd.size() << " images (" << SecondsSince(t_data)
            << " s)\n";

  const std::string out = cl.Get("out", "");
  fs::create_directories(out);
  for (const bool points : {true, false}) {
    pl_slam::VocabularyOptions o = vo;
    o.kind = points ? "orb" : "lbd";
    if (!points) o.depth = cl.GetInt("line-depth", vo.depth);
    const auto t0 = Clock::now();
    const pl_slam::Vocabulary voc = pl_slam::Vocabulary::Train(points ? orb : lbd, o);
    const std::string path = out + "/" + o.kind + ".plvoc";
    voc.Save(path);
    std::cout << voc.Describe() << " (" << SecondsSince(t0) << " s) -> " << path << " ("
              << fs::file_size(path) << " bytes)\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_train_vocabulary", [&] { return Run(argc, argv); });
}
