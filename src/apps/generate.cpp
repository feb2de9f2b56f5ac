// pl_slam_generate: renders a synthetic stereo sequence with exact ground truth and writes it
// as an EuRoC ASL folder and/or a rosbag (left/right images + camera_info with identical
// stamps, ground truth as geometry_msgs/PoseStamped).
#include <filesystem>
#include <iostream>

#include "pl_slam/io/euroc.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_generate --scene room|corridor|fast_turn [--euroc DIR] [--bag FILE] [options]\n"
    "  --euroc DIR           write an EuRoC ASL folder (DIR/mav0/...)\n"
    "  --bag FILE            write a rosbag (/cam0/image_raw, /cam1/image_raw, camera_info,\n"
    "                        /ground_truth/pose)\n"
    "  --frames N            number of frames (default: the scene's own length)\n"
    "  --loops K             room: go round the loop K times (default 1; length scales)\n"
    "  --rate HZ             frame rate (default 20)\n"
    "  --noise SIGMA         image noise, grey levels (default 2)\n"
    "  --seed S              random seed (default 1)\n"
    "  --exposure-change     vary exposure over the sequence\n"
    "  --baseline M          stereo baseline in metres (default 0.11; smaller = far-scene\n"
    "                        disparities, like a car's camera on a road)\n"
    "  --start-time S        first timestamp in seconds (default 1000)\n";

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(argc, argv,
                                {"scene", "euroc", "bag", "frames", "loops", "rate", "noise",
                                 "seed", "start-time", "baseline"},
                                {"exposure-change", "help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (!cl.Has("scene") || (!cl.Has("euroc") && !cl.Has("bag")) || !cl.positional().empty()) {
    std::cerr << kUsage;
    return 2;
  }
  pl_slam::sim::SequenceOptions opt;
  opt.scene = pl_slam::sim::ParseSceneKind(cl.Get("scene", ""));
  opt.num_frames = cl.GetInt("frames", opt.num_frames);
  opt.loops = cl.GetInt("loops", opt.loops);
  opt.rate_hz = cl.GetDouble("rate", opt.rate_hz);
  opt.noise_sigma = cl.GetDouble("noise", opt.noise_sigma);
  opt.seed = static_cast<uint64_t>(cl.GetInt("seed", static_cast<int>(opt.seed)));
  opt.exposure_change = cl.Has("exposure-change");
  // ROS time cannot be negative and a zero stamp means "unset" to many tools.
  opt.start_time_s = cl.GetDouble("start-time", 1000.0);
  opt.baseline = cl.GetDouble("baseline", opt.baseline);
  pl_slam::sim::SyntheticSequence seq(opt);

  std::unique_ptr<pl_slam::EurocWriter> euroc;
  std::unique_ptr<pl_slam::ros_layer::StereoBagWriter> bag;
  if (cl.Has("euroc"))
    euroc = std::make_unique<pl_slam::EurocWriter>(cl.Get("euroc", ""), seq.camera(), opt.rate_hz);
  if (cl.Has("bag")) {
    const std::filesystem::path p(cl.Get("bag", ""));
    if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
    bag = std::make_unique<pl_slam::ros_layer::StereoBagWriter>(p.string(), seq.camera());
  }
  std::cout << "pl_slam_generate: scene " << pl_slam::sim::SceneKindName(opt.scene) << ", "
            << seq.size() << " frames" << std::flush;
  pl_slam::StereoFrame frame;
  int n = 0;
  while (seq.Next(&frame)) {
    if (euroc) euroc->Add(frame);
    if (bag) bag->Write(frame);
    if (++n % 100 == 0) std::cout << "." << std::flush;
  }
  if (euroc) euroc->Finish(seq.ground_truth());
  if (bag) {
    bag->WriteGroundTruth(seq.ground_truth());
    bag->Close();
  }
  std::cout << " done";
  if (cl.Has("euroc")) std::cout << "; EuRoC folder " << cl.Get("euroc", "");
  if (cl.Has("bag")) std::cout << "; bag " << cl.Get("bag", "");
  std::cout << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_generate", [&] { return Run(argc, argv); });
}
