// OpenDatasetFolder: layout detection for the dataset sources.
#include <filesystem>

#include "pl_slam/io/euroc.h"
#include "pl_slam/io/kitti.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/util/error.h"

namespace pl_slam {

std::unique_ptr<StereoSource> OpenDatasetFolder(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path dir(path);
  std::error_code ec;
  auto is_dir = [&ec](const fs::path& p) { return fs::is_directory(p, ec); };
  if (!fs::exists(dir, ec)) throw InputError(path + ": no such file or folder");
  const std::string expected =
      " (expected an EuRoC ASL folder with mav0/ or cam0/ and cam1/, or a KITTI odometry "
      "folder with calib.txt, image_0/, image_1/)";
  if (!is_dir(dir)) throw InputError(path + ": not a dataset folder" + expected);
  if (is_dir(dir / "mav0") || (is_dir(dir / "cam0") && is_dir(dir / "cam1"))) {
    return std::make_unique<EurocSource>(path);
  }
  if (fs::is_regular_file(dir / "calib.txt", ec) && is_dir(dir / "image_0") &&
      is_dir(dir / "image_1")) {
    return std::make_unique<KittiSource>(path);
  }
  throw InputError(path + ": not a dataset folder" + expected);
}

}  // namespace pl_slam
