// pl_slam_generate: renders a synthetic stereo sequence with exact ground truth and writes it
// as an EuRoC ASL folder and/or a rosbag (left/right images + camera_info with identical
// stamps, ground truth as geometry_msgs/PoseStamped).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "pl_slam/io/euroc.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_generate --scene NAME [--euroc DIR] [--bag FILE] [options]\n"
    "  --scene NAME          room, corridor, fast_turn, a low-texture scene (lowtex_corner,\n"
    "                        lowtex_straight, lowtex_spin, lowtex_doorway, lowtex_wall,\n"
    "                        lowtex_office) or a street scene (street_straight, street_curve,\n"
    "                        street_junction, street_avenue, street_s_bend: a KITTI-like car\n"
    "                        camera, 1241x376 px, focal 718.856 px, baseline 0.54 m, 10 Hz)\n"
    "  --euroc DIR           write an EuRoC ASL folder (DIR/mav0/...)\n"
    "  --bag FILE            write a rosbag (/cam0/image_raw, /cam1/image_raw, camera_info,\n"
    "                        /ground_truth/pose)\n"
    "  --frames N            number of frames (default: the scene's own length)\n"
    "  --loops K             room: go round the loop K times (default 1; length scales)\n"
    "  --rate HZ             frame rate (default 20; street scenes 10)\n"
    "  --noise SIGMA         image noise, grey levels (default 2)\n"
    "  --seed S              image noise seed (default 1)\n"
    "  --world-seed S        world seed: textures and, for lowtex and street scenes, layout\n"
    "                        (default 7)\n"
    "  --bare                lowtex scenes: the bare variant (no posters, floor tiles,\n"
    "                        ceiling grid or lights, wall seams)\n"
    "  --blur SIGMA          Gaussian blur in pixels (default: 0.6 for lowtex and street\n"
    "                        scenes, else 0)\n"
    "  --vignetting F        corner darkening fraction (default: 0.08 lowtex and street,\n"
    "                        else 0)\n"
    "  --exposure PRESET     normal (default), dim (gain 0.45) or bright (gain 1.4, clips)\n"
    "  --edges FILE          also write the visible ground-truth structural edges of every\n"
    "                        left image as CSV: frame,stamp_ns,edge,u0,v0,u1,v1 (pixels)\n"
    "  --exposure-change     vary exposure over the sequence\n"
    "  --baseline M          stereo baseline in metres (default 0.11, street scenes 0.54)\n"
    "  --start-time S        first timestamp in seconds (default 1000)\n";

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv,
      {"scene", "euroc", "bag", "frames", "loops", "rate", "noise", "seed", "start-time",
       "baseline", "world-seed", "blur", "vignetting", "exposure", "edges"},
      {"exposure-change", "bare", "help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (!cl.Has("scene") || (!cl.Has("euroc") && !cl.Has("bag")) || !cl.positional().empty()) {
    std::cerr << kUsage;
    return 2;
  }
  pl_slam::sim::SequenceOptions opt =
      pl_slam::sim::DefaultSequenceOptions(pl_slam::sim::ParseSceneKind(cl.Get("scene", "")));
  opt.num_frames = cl.GetInt("frames", opt.num_frames);
  opt.loops = cl.GetInt("loops", opt.loops);
  opt.rate_hz = cl.GetDouble("rate", opt.rate_hz);
  opt.noise_sigma = cl.GetDouble("noise", opt.noise_sigma);
  opt.seed = static_cast<uint64_t>(cl.GetInt("seed", static_cast<int>(opt.seed)));
  opt.exposure_change = cl.Has("exposure-change");
  // ROS time cannot be negative and a zero stamp means "unset" to many tools.
  opt.start_time_s = cl.GetDouble("start-time", 1000.0);
  opt.baseline = cl.GetDouble("baseline", opt.baseline);
  opt.world_seed = static_cast<uint64_t>(cl.GetInt("world-seed", static_cast<int>(opt.world_seed)));
  opt.bare = cl.Has("bare");
  opt.blur_sigma = cl.GetDouble("blur", opt.blur_sigma);
  opt.vignetting = cl.GetDouble("vignetting", opt.vignetting);
  if (cl.Has("exposure")) pl_slam::sim::ApplyExposurePreset(cl.Get("exposure", ""), &opt);
  pl_slam::sim::SyntheticSequence seq(opt);
  std::ofstream edges;
  if (cl.Has("edges")) {
    const std::filesystem::path p(cl.Get("edges", ""));
    if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
    edges.open(p);
    if (!edges) throw pl_slam::InputError("cannot write " + p.string());
    edges << "frame,stamp_ns,edge,u0,v0,u1,v1\n";
  }

  std::unique_ptr<pl_slam::EurocWriter> euroc;
  std::unique_ptr<pl_slam::ros_layer::StereoBagWriter> bag;
  if (cl.Has("euroc"))
    euroc = std::make_unique<pl_slam::EurocWriter>(cl.Get("euroc", ""), seq.camera(), opt.rate_hz);
  if (cl.Has("bag")) {
    const std::filesystem::path p(cl.Get("bag", ""));
    if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
    bag = std::make_unique<pl_slam::ros_layer::StereoBagWriter>(p.string(), seq.camera());
  }
  std::cout << "pl_slam_generate: scene " << pl_slam::sim::SceneKindName(opt.scene)
            << (opt.bare ? " (bare)" : "") << ", " << seq.size() << " frames" << std::flush;
  pl_slam::StereoFrame frame;
  int n = 0;
  while (seq.Next(&frame)) {
    if (euroc) euroc->Add(frame);
    if (bag) bag->Write(frame);
    if (edges.is_open()) {
      for (const auto& e : seq.VisibleStructuralEdges(frame.index)) {
        edges << frame.index << "," << frame.stamp_ns << "," << e.edge << "," << e.a.x() << ","
              << e.a.y() << "," << e.b.x() << "," << e.b.y() << "\n";
      }
    }
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
