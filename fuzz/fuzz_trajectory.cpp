// Fuzz target: the trajectory readers (TUM, KITTI poses, EuRoC ground-truth csv) used for
// ground truth and evaluation. The first byte picks the format, the rest is the content; a
// trajectory that reads must also format and read back.
#include "fuzz_util.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace fuzz {

int Trajectory(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text = pl_slam::fuzz::AsString(data + 1, size - 1);
  pl_slam::fuzz::ExpectAcceptOrRefuse([&] {
    pl_slam::Trajectory traj;
    switch (data[0] % 3) {
      case 0:
        traj = pl_slam::ParseTumTrajectory(text, "trajectory.tum");
        break;
      case 1:
        traj = pl_slam::ParseKittiTrajectory(text, "poses.txt", {});
        break;
      default:
        traj = pl_slam::ParseEurocTrajectory(text, "data.csv");
        break;
    }
    const std::string tum = pl_slam::FormatTrajectory(traj, pl_slam::TrajectoryFormat::kTum);
    (void)pl_slam::ParseTumTrajectory(tum, "round_trip.tum");
  });
  return 0;
}

}  // namespace fuzz
}  // namespace pl_slam

#ifndef PL_SLAM_FUZZ_NO_ENTRY
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pl_slam::fuzz::Trajectory(data, size);
}
#endif
