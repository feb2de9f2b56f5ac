#include "pl_slam/eval/association.h"

#include <gtest/gtest.h>

#include "eval_test_util.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {
namespace {

// The loop of MakeLoop evaluated at an arbitrary time (the analytic truth).
SE3 LoopPose(double t, double t0 = 100.0) {
  const double s = (t - t0) * 0.4;
  const Eigen::Vector3d pos(2.0 * std::cos(s), 1.5 * std::sin(s), 0.5 * std::sin(2.0 * s));
  const Eigen::Vector3d rot(0.1 * std::sin(s), 0.05 * std::cos(3.0 * s), s);
  return SE3(ExpSO3(rot), pos);
}

Trajectory EstimateAt(const std::vector<double>& times) {
  Trajectory est;
  for (double t : times) {
    StampedPose p;
    p.t = t;
    p.T_w_c = LoopPose(t);
    est.push_back(p);
  }
  return est;
}

TEST(InterpolatePose, EndpointsAndMidpoint) {
  const SE3 a(ExpSO3(Eigen::Vector3d(0, 0, 0.2)), Eigen::Vector3d(0, 0, 0));
  const SE3 b(ExpSO3(Eigen::Vector3d(0, 0, 0.6)), Eigen::Vector3d(2, 4, 6));
  EXPECT_LT((InterpolatePose(a, b, 0.0).matrix() - a.matrix()).norm(), 1e-12);
  EXPECT_LT((InterpolatePose(a, b, 1.0).matrix() - b.matrix()).norm(), 1e-12);
  const SE3 m = InterpolatePose(a, b, 0.25);
  EXPECT_LT((m.translation() - Eigen::Vector3d(0.5, 1, 1.5)).norm(), 1e-12);
  EXPECT_LT((LogSO3(m.rotation()) - Eigen::Vector3d(0, 0, 0.3)).norm(), 1e-12);
}

TEST(Associate, InterpolatesDenseGroundTruthAtSparseEstimates) {
  // 200 Hz ground truth, 20 Hz estimate stamped at varying offsets between gt samples.
  const Trajectory gt = testing::MakeLoop(200.0, 20.0);
  std::vector<double> times;
  for (int i = 0; i < 400; ++i) times.push_back(100.0 + 0.0004 + 0.0007 * (i % 7) + 0.05 * i);
  const Trajectory est = EstimateAt(times);

  const Association a = AssociateTrajectories(est, gt);
  ASSERT_EQ(a.size(), est.size());
  EXPECT_EQ(a.interpolated, est.size());
  EXPECT_EQ(a.unmatched, 0u);
  double worst_t = 0.0;
  double worst_r = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_DOUBLE_EQ(a.gt[i].t, a.est[i].t);
    EXPECT_EQ(a.est_indices[i], i);
    const SE3 err = a.gt[i].T_w_c.inverse() * LoopPose(a.est[i].t);
    worst_t = std::max(worst_t, err.translation().norm());
    worst_r = std::max(worst_r, err.RotationAngle());
  }
  // Linear interpolation over 5 ms of a 0.8 m/s curve: error ~ a dt^2 / 8 ~ 1e-6 m.
  EXPECT_LT(worst_t, 1e-5);
  EXPECT_LT(worst_r, 1e-5);

  // Nearest-sample association is off by up to half a sample (~2 mm): interpolation matters.
  AssociationOptions nearest;
  nearest.interpolate = false;
  const Association b = AssociateTrajectories(est, gt, nearest);
  ASSERT_EQ(b.size(), est.size());
  EXPECT_EQ(b.interpolated, 0u);
  double worst_nearest = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    worst_nearest = std::max(
        worst_nearest, (b.gt[i].T_w_c.translation() - LoopPose(b.est[i].t).translation()).norm());
  }
  EXPECT_GT(worst_nearest, 1e-3);
}

TEST(Associate, RespectsMaxDtAndFallsBackToNearest) {
  Trajectory gt = testing::MakeLoop(20.0, 5.0);  // stamps 100.00, 100.05, ... 105.00
  // Remove the samples at 102.00..102.20 to make a 0.25 s gap.
  Trajectory holed;
  for (const auto& p : gt) {
    if (p.t < 101.99 || p.t > 102.21) holed.push_back(p);
  }
  const Trajectory est = EstimateAt({99.0,     // before the gt span: unmatched
                                     99.99,    // 10 ms before the first gt sample: nearest
                                     100.51,   // bracketed, both within 20 ms? no: 10 / 40 ms
                                     101.96,   // 10 ms after 101.95, next gt at 102.25: nearest
                                     102.10,   // in the gap: unmatched
                                     105.015,  // 15 ms after the last sample: nearest
                                     106.0});  // after: unmatched
  const Association a = AssociateTrajectories(est, holed);
  ASSERT_EQ(a.size(), 4u);
  EXPECT_EQ(a.unmatched, 3u);
  EXPECT_EQ(a.interpolated, 0u);
  EXPECT_NEAR(a.est[0].t, 99.99, 1e-12);
  EXPECT_LT((a.gt[0].T_w_c.translation() - holed.front().T_w_c.translation()).norm(), 1e-12);
  // 100.51 is 10 ms after 100.50 and 40 ms before 100.55: nearest (100.50) only.
  EXPECT_LT((a.gt[1].T_w_c.translation() - LoopPose(100.50).translation()).norm(), 1e-12);
  EXPECT_LT((a.gt[2].T_w_c.translation() - LoopPose(101.95).translation()).norm(), 1e-12);
  EXPECT_LT((a.gt[3].T_w_c.translation() - holed.back().T_w_c.translation()).norm(), 1e-12);
  EXPECT_EQ(a.est_indices, (std::vector<std::size_t>{1, 2, 3, 5}));

  // A wider window interpolates 100.51 between 100.50 and 100.55.
  const Association wide = AssociateTrajectories(est, holed, AssociationOptions{0.05, true});
  EXPECT_GE(wide.interpolated, 1u);
}

TEST(Associate, UnsortedInputsAndEmpty) {
  Trajectory gt = testing::MakeLoop(20.0, 2.0);
  std::reverse(gt.begin(), gt.end());
  const Trajectory est = EstimateAt({101.0, 100.5});
  const Association a = AssociateTrajectories(est, gt);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_LT(a.est[0].t, a.est[1].t);
  EXPECT_LT((a.gt[0].T_w_c.translation() - LoopPose(100.5).translation()).norm(), 1e-12);

  EXPECT_TRUE(AssociateTrajectories({}, gt).empty());
  const Association none = AssociateTrajectories(est, {});
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(none.unmatched, 2u);
  EXPECT_THROW(AssociateTrajectories(est, gt, AssociationOptions{0.0, true}), ConfigError);
  EXPECT_THROW(AssociateTrajectories(est, gt, AssociationOptions{-1.0, true}), ConfigError);
}

}  // namespace
}  // namespace eval
}  // namespace pl_slam
