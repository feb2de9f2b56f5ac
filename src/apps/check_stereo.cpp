// pl_slam_check_stereo: checks a dataset's stereo calibration against its own images. Pairs
// of left images of the moving camera give every point's depth up to scale; the stereo
// disparities must be those depths' inverses up to scale too, and any constant offset between
// them is a principal-point error of the rectified pair (the camera's doffs). Prints the
// offset the images imply next to the calibration's, and the --doffs value to run with.
#include <iomanip>
#include <iostream>
#include <vector>

#include "pl_slam/camera/stereo_check.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_check_stereo INPUT [--max-frames N] [--verbose]\n"
    "  INPUT            EuRoC ASL folder or KITTI odometry folder (rectified by the reader)\n"
    "  --max-frames N   frames read (default 300); the camera must move (not only rotate)\n"
    "                   through a scene with near and far points\n"
    "  --verbose        one line per pair of frames\n"
    "Exit status: 0 the images agree with the calibration; 3 they imply a different doffs (fix\n"
    "the calibration, or run pl_slam_offline with --doffs); 4 too few usable pairs to tell;\n"
    "1 unreadable input; 2 bad usage.\n";

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(argc, argv, {"max-frames"}, {"verbose", "help"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (cl.positional().size() != 1) throw pl_slam::ConfigError("expected one INPUT folder");
  const int max_frames = cl.GetInt("max-frames", 300);
  if (max_frames < 3) throw pl_slam::ConfigError("--max-frames must be >= 3");
  auto source = pl_slam::OpenDatasetFolder(cl.positional()[0]);
  const pl_slam::StereoCamera cam = source->camera();
  const int frames = static_cast<int>(std::min<size_t>(source->size(), max_frames));
  std::cout << "pl_slam_check_stereo: " << source->Describe() << ", " << frames
            << " frames, anchors every " << pl_slam::StereoOffsetAnchorStride(frames) << "\n";
  const bool verbose = cl.Has("verbose");
  const pl_slam::StereoOffsetMeasurement m = pl_slam::MeasureStereoOffset(
      source.get(), max_frames, [&](int anchor, int i, const pl_slam::StereoPairCheck& c) {
        if (!verbose) return;
        std::cout << "  frames " << anchor << " -> " << i << ": ";
        if (c.usable)
          std::cout << std::fixed << std::setprecision(2) << "doffs " << c.doffs << " +- "
                    << c.sigma << " px, " << c.points << " points, disparities " << c.disparity_lo
                    << "-" << c.disparity_hi << " px, rows " << c.row_offset << " px, moved "
                    << c.translation << " m, " << c.rotation_deg << " deg\n";
        else
          std::cout << "not usable: " << c.reason << "\n";
      });
  const int tried = m.tried;
  const pl_slam::StereoCheckSummary& s = m.summary;
  std::cout << std::fixed << std::setprecision(2);
  if (!m.conclusive()) {
    std::cout << "pl_slam_check_stereo: only " << s.pairs << " of " << tried
              << " pairs usable: cannot tell (needs translation through near and far points)\n";
    return 4;
  }
  std::cout << "pl_slam_check_stereo: " << s.pairs << " of " << tried
            << " pairs usable: the images imply doffs = " << s.doffs << " +- " << s.doffs_error
            << " px (median over pairs +- its standard error; IQR " << s.doffs_iqr
            << "); the calibration says " << cam.doffs << " px; stereo matches' row offset "
            << s.row_offset << " px\n";
  const double difference = s.doffs - cam.doffs;
  if (!pl_slam::StereoOffsetDiffers(s, cam.doffs)) {
    std::cout << "pl_slam_check_stereo: consistent with the calibration\n";
    return 0;
  }
  std::cout << "pl_slam_check_stereo: the disparities are offset by " << -difference
            << " px from the calibration's: stereo depths are wrong (by ~" << std::setprecision(0)
            << 100.0 * std::abs(difference) / 10.0 << "% at 10 px of disparity). Fix the right "
            << "camera's principal point, or run pl_slam_offline with --doffs "
            << std::setprecision(2) << s.doffs << " (nodelet without camera_info: camera.doffs)\n";
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_check_stereo", [&] { return Run(argc, argv); });
}
