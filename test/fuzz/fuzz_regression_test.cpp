// Runs the fuzz targets' code (fuzz/fuzz_*.cpp) on every committed input in
// fuzz/corpus/<target>/: the seeds, and every input a fuzzing run found crashing (saved there
// by scripts/run_fuzzers.sh once fixed), so a fixed crash cannot come back unnoticed. A crash
// or an undocumented exception fails the test; the documented refusals are InputError and
// ConfigError.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "fuzz_util.h"
#include "pl_slam/io/text_util.h"
#include "pl_slam/map/map_io.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> Inputs(const std::string& target) {
  const fs::path dir = fs::path(PL_SLAM_SOURCE_DIR) / "fuzz" / "corpus" / target;
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string Read(const fs::path& p) { return text::ReadFile(p.string()); }

using Target = int (*)(const uint8_t*, size_t);

void RunAll(const std::string& name, Target target) {
  const auto files = Inputs(name);
  ASSERT_FALSE(files.empty()) << "fuzz/corpus/" << name << " has no inputs";
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    const std::string bytes = Read(f);
    EXPECT_EQ(target(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), 0);
  }
}

TEST(FuzzRegressionTest, ConfigInputs) { RunAll("config", &fuzz::Config); }
TEST(FuzzRegressionTest, CalibrationInputs) { RunAll("calibration", &fuzz::Calibration); }
TEST(FuzzRegressionTest, TrajectoryInputs) { RunAll("trajectory", &fuzz::Trajectory); }
TEST(FuzzRegressionTest, MapLoaderInputs) { RunAll("map_loader", &fuzz::MapLoader); }

TEST(FuzzRegressionTest, ShippedConfigsGoThroughTheConfigTarget) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(PL_SLAM_SOURCE_DIR) / "config")) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().string());
    const std::string bytes = Read(e.path());
    EXPECT_EQ(fuzz::Config(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), 0);
    ++n;
  }
  EXPECT_GE(n, 4);
}

TEST(FuzzRegressionTest, EmptyMapAndItsMutationsGoThroughTheMapTarget) {
  // A real file (an empty map) and every single-byte change of it: with the checksum repaired
  // by the target, each reaches the section parsers.
  Map map;
  const std::string bytes = SerializeMap(map);
  for (size_t i = 0; i < bytes.size(); ++i) {
    for (int delta : {1, 0x80}) {
      std::string m = bytes;
      m[i] = static_cast<char>(m[i] + delta);
      ASSERT_EQ(fuzz::MapLoader(reinterpret_cast<const uint8_t*>(m.data()), m.size()), 0);
    }
  }
}

}  // namespace
}  // namespace pl_slam
