// Map reuse: a map saved after a run, loaded into a new system in localisation-only mode,
// relocalises the camera on the same sequence and tracks it with the first run's accuracy,
// without adding keyframes. A corrupt map file is refused and the running map kept.
#include <gtest/gtest.h>

#include <fstream>

#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/error.h"
#include "test_util/system_options.h"
#include "test_util/temp_dir.h"

namespace pl_slam {
namespace {

SystemOptions Options() { return testing_util::SequentialWithVocabulary(); }

TEST(MapReuseTest, SavedMapRelocalisesAndTracksInLocalisationMode) {
  testing_util::TempDir dir;
  const std::string path = dir.path().string() + "/room.plmap";
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  sim::SyntheticSequence seq(so);
  const int n = 160;
  std::vector<StereoFrame> frames;
  for (int i = 0; i < n; ++i) frames.push_back(seq.Render(i));
  const SE3 T_gt0_inv = seq.ground_truth()[0].T_w_c.inverse();
  auto error_of = [&](int i, const SE3& T_w_c) -> Eigen::Vector3d {
    return (T_gt0_inv * seq.ground_truth()[i].T_w_c).translation() - T_w_c.translation();
  };

  size_t keyframes = 0;
  double first_run_error = 0.0;
  {
    SlamSystem mapping_run(seq.camera(), Options());
    for (int i = 0; i < n; ++i) {
      const FrameResult r = mapping_run.Process(frames[i]);
      if (r.pose_valid) first_run_error = std::max(first_run_error, error_of(i, r.T_w_c).norm());
    }
    mapping_run.Flush();
    mapping_run.SaveMap(path);
    keyframes = mapping_run.map().counts().keyframes;
  }
  ASSERT_GT(keyframes, 5u);

  SlamSystem reuse(seq.camera(), Options());
  reuse.LoadMap(path);
  reuse.SetLocalizationOnly(true);
  EXPECT_EQ(reuse.map().counts().keyframes, keyframes);
  // Start in the middle of the mapped stretch: the first pose must come from relocalisation.
  int first_valid = -1;
  double worst = 0.0;
  for (int i = 80; i < n; ++i) {
    const FrameResult r = reuse.Process(frames[i]);
    if (!r.pose_valid) continue;
    if (first_valid < 0) first_valid = i;
    worst = std::max(worst, error_of(i, r.T_w_c).norm());
  }
  reuse.Flush();
  std::cout << "first run max error " << first_run_error << " m; reuse: first pose at frame "
            << first_valid << ", max error " << worst << " m\n";
  ASSERT_GE(first_valid, 80);
  EXPECT_LE(first_valid, 85);
  EXPECT_LT(worst, std::max(0.03, 2.0 * first_run_error));
  EXPECT_EQ(reuse.map().counts().keyframes, keyframes) << "localisation only adds nothing";

  // A corrupt file is refused by name and the loaded map stays.
  const std::string bad = dir.path().string() + "/bad.plmap";
  std::ofstream(bad) << "PLSLAMAP garbage";
  try {
    reuse.LoadMap(bad);
    FAIL() << "corrupt map accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.plmap"), std::string::npos) << e.what();
  }
  EXPECT_EQ(reuse.map().counts().keyframes, keyframes);
}

}  // namespace
}  // namespace pl_slam
