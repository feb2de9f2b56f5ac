// Regression on a short hard corridor: the first 90-degree corner of the low-texture family's
// Z corridor (plain graded walls, door frames, rails; 10-60 ORB corners per frame at the
// corner; sensor blur and vignetting), on two world layouts that are not among the family's
// tuning seeds (1-3). Every frame must be tracked and the trajectory stay within 0.1 % of the
// path (ATE, SE(3)); today's figures are 0.04 and 0.06 %, the family's target 0.05 %
// (docs/BENCHMARKS.md has the whole family).
#include <gtest/gtest.h>

#include "pl_slam/eval/evaluation.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"

namespace pl_slam {
namespace {

class LowtexCornerTest : public ::testing::TestWithParam<uint64_t> {};

TEST_P(LowtexCornerTest, EveryFrameIsTrackedThroughTheCorner) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kLowtexCorner;
  so.world_seed = GetParam();
  so.num_frames = 140;  // the first leg and the first corner
  const sim::SyntheticSequence seq(so);
  SystemOptions opt;
  opt.mapping.threaded = false;  // deterministic
  SlamSystem sys(seq.camera(), opt);
  int lost = 0;
  std::vector<double> times;
  for (int i = 0; i < so.num_frames; ++i) {
    const FrameResult r = sys.Process(seq.Render(i));
    EXPECT_TRUE(r.pose_valid) << "frame " << i << ": " << r.warning;
    lost += !r.pose_valid;
    times.push_back(seq.ground_truth()[i].t);
  }
  Trajectory gt(seq.ground_truth().begin(), seq.ground_truth().begin() + so.num_frames);
  const eval::EvaluationResult ev = eval::EvaluateTrajectory(sys.trajectory(), gt, times);
  const double ratio = ev.ate.translation.rmse / ev.gt_path_length;
  std::cout << "lowtex_corner world seed " << GetParam() << ", " << so.num_frames << " frames, "
            << ev.gt_path_length << " m: lost " << lost << ", ATE "
            << ev.ate.translation.rmse * 1000 << " mm (" << ratio * 100 << " % of the path)\n";
  EXPECT_EQ(lost, 0);
  EXPECT_GT(ev.gt_path_length, 5.0);
  EXPECT_LT(ratio, 0.001);
}

INSTANTIATE_TEST_SUITE_P(HeldOutLayouts, LowtexCornerTest, ::testing::Values(4u, 5u));

}  // namespace
}  // namespace pl_slam
