// pl_slam_convert: EuRoC ASL folders and KITTI odometry folders to a rosbag in the package's
// topic layout (/cam0/image_raw, /cam1/image_raw, /cam0/camera_info, /cam1/camera_info,
// /ground_truth/pose), ready for `rosbag play` into the nodelet or for pl_slam_offline.
#include <cmath>
#include <iomanip>
#include <iostream>

#include "pl_slam/ros/dataset_to_bag.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_convert INPUT_FOLDER OUTPUT.bag [--raw] [--max-frames N] [--time-offset S]\n"
    "  INPUT_FOLDER      an EuRoC ASL folder (mav0/ or cam0/ + cam1/ with sensor.yaml) or a\n"
    "                    KITTI odometry sequence (calib.txt, image_0/, image_1/)\n"
    "  OUTPUT.bag        written as OUTPUT.bag.tmp and renamed when complete\n"
    "  --raw             EuRoC: keep the distorted images; camera_info carries K, D (plumb_bob),\n"
    "                    R and P of the stereo rectification, so the nodelet rectifies.\n"
    "                    Default: rectified images, camera_info with D = 0, R = I\n"
    "  --max-frames N    convert the first N frames only (default: all)\n"
    "  --time-offset S   add S seconds to every stamp (default: 0, or 1000 when the sequence\n"
    "                    starts before 1 s, as KITTI does: ROS time 0 means 'unset')\n"
    "  --left-frame F    frame_id of the left images (default cam0); --right-frame (cam1)\n"
    "Topics: /cam0/image_raw, /cam1/image_raw (mono8), /cam0/camera_info, /cam1/camera_info,\n"
    "/ground_truth/pose (geometry_msgs/PoseStamped of the rectified left camera, when the\n"
    "dataset has ground truth).\n";

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv, {"max-frames", "time-offset", "left-frame", "right-frame"}, {"raw", "help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (cl.positional().size() != 2) {
    std::cerr << "pl_slam_convert: error: expected INPUT_FOLDER and OUTPUT.bag\n" << kUsage;
    return 2;
  }
  pl_slam::ros_layer::ConvertOptions opt;
  opt.raw = cl.Has("raw");
  opt.max_frames = cl.GetInt("max-frames", 0);
  if (cl.Has("time-offset")) opt.time_offset_s = cl.GetDouble("time-offset", 0.0);
  opt.left_frame = cl.Get("left-frame", opt.left_frame);
  opt.right_frame = cl.Get("right-frame", opt.right_frame);
  const std::string input = cl.positional()[0], output = cl.positional()[1];

  // Progress dots go on their own line so an error message always starts a fresh line.
  bool dots = false;
  pl_slam::ros_layer::ConvertSummary summary;
  try {
    summary = pl_slam::ros_layer::ConvertDatasetToBag(
        input, output, opt, [&dots](std::size_t done, std::size_t total) {
          if (!dots)
            std::cout << "pl_slam_convert: converting " << total << " frames " << std::flush;
          dots = true;
          if (done % 50 == 0 || done == total) std::cout << "." << std::flush;
        });
  } catch (...) {
    if (dots) std::cout << std::endl;
    throw;
  }
  const pl_slam::StereoCamera& c = summary.camera;
  std::cout << " done\n"
            << "pl_slam_convert: wrote " << output << ": " << summary.kind << ", " << summary.frames
            << " stereo pairs (" << (summary.raw ? "raw, rectified by the consumer" : "rectified")
            << "), " << summary.poses << " ground-truth poses, stamps offset by "
            << summary.time_offset_s << " s; rectified camera " << c.width << "x" << c.height
            << " fx " << std::fixed << std::setprecision(2) << c.fx << " baseline "
            << std::setprecision(4) << c.baseline << " m\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_convert", [&] { return Run(argc, argv); });
}
