// Fuzz target: the dataset calibration and timestamp readers (EuRoC sensor.yaml, KITTI
// calib.txt and times.txt). The first byte picks the reader, the rest is the file content.
#include "fuzz_util.h"
#include "pl_slam/io/euroc.h"
#include "pl_slam/io/kitti.h"

namespace pl_slam {
namespace fuzz {

int Calibration(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text = pl_slam::fuzz::AsString(data + 1, size - 1);
  pl_slam::fuzz::ExpectAcceptOrRefuse([&] {
    switch (data[0] % 3) {
      case 0: {
        const pl_slam::RawCameraCalibration c = pl_slam::ParseEurocCameraYaml(text, "sensor.yaml");
        (void)pl_slam::FormatEurocCameraYaml(c, "fuzz");
        break;
      }
      case 1:
        (void)pl_slam::ParseKittiCalibration(text, "calib.txt", 1241, 376);
        break;
      default:
        (void)pl_slam::ParseKittiTimes(text, "times.txt");
        break;
    }
  });
  return 0;
}

}  // namespace fuzz
}  // namespace pl_slam

#ifndef PL_SLAM_FUZZ_NO_ENTRY
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pl_slam::fuzz::Calibration(data, size);
}
#endif
