// Access to ../shared/datasets (real data beside the repository on developer machines and in
// CI, absent on a user's clone: tests skip with a message then) and small file helpers.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace pl_slam {
namespace testing_util {

/// ../shared/datasets relative to the package root; empty when absent.
inline std::string DatasetsDir() {
  for (const std::string& base : {std::string(PL_SLAM_SOURCE_DIR) + "/../shared/datasets",
                                  std::string("../shared/datasets")}) {
    if (std::filesystem::is_directory(base)) return base;
  }
  return "";
}

/// Writes `content` to `path` as is (binary), replacing the file.
inline void WriteText(const std::filesystem::path& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary);
  out << content;
}

}  // namespace testing_util
}  // namespace pl_slam
