#include "pl_slam/eval/metrics.h"

#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "eval_test_util.h"
#include "pl_slam/eval/evaluation.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {
namespace {

Association PairWith(const Trajectory& gt, const std::function<SE3(std::size_t, const SE3&)>& f) {
  Association a;
  a.gt = gt;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    StampedPose p = gt[i];
    p.T_w_c = f(i, gt[i].T_w_c);
    a.est.push_back(p);
    a.est_indices.push_back(i);
  }
  return a;
}

// Straight line along x, 0.1 m per frame, with the camera yawing slowly (rotation must not
// matter for the translation metrics).
Trajectory StraightLine(int n, double step = 0.1) {
  Trajectory traj;
  for (int i = 0; i < n; ++i) {
    StampedPose p;
    p.t = 10.0 + 0.05 * i;
    p.T_w_c = SE3(ExpSO3(Eigen::Vector3d(0.0, 0.0, 0.01 * i)), Eigen::Vector3d(step * i, 0.0, 1.0));
    traj.push_back(p);
  }
  return traj;
}

TEST(ErrorStats, KnownValues) {
  const ErrorStats s = ComputeErrorStats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(ComputeErrorStats({5.0, 1.0, 3.0}).median, 3.0);
  const ErrorStats empty = ComputeErrorStats({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_EQ(empty.rmse, 0.0);
}

TEST(Ate, PerfectlyTransformedTrajectoryIsZero) {
  std::mt19937 rng(1);
  const Trajectory gt = testing::MakeLoop(20.0, 15.0);
  const SE3 T = testing::RandomSE3(rng);
  const Association a = PairWith(gt, [&](std::size_t, const SE3& g) { return T * g; });
  const AteResult se3 = ComputeAte(a, AlignmentMode::kSE3);
  EXPECT_LT(se3.translation.rmse, 1e-9);
  EXPECT_LT(se3.translation.max, 1e-9);
  EXPECT_LT(se3.rotation_deg.max, 1e-6);
  EXPECT_EQ(se3.translation.count, gt.size());
  EXPECT_LT(ComputeAte(a, AlignmentMode::kFirstPose).translation.rmse, 1e-9);

  // Sim3: the estimate at 1 / 2.5 of the true scale.
  const Association s = PairWith(gt, [&](std::size_t, const SE3& g) {
    const SE3 tg = T * g;
    return SE3(tg.so3(), tg.translation() / 2.5);
  });
  const AteResult sim3 = ComputeAte(s, AlignmentMode::kSim3);
  EXPECT_NEAR(sim3.alignment.scale, 2.5, 1e-9);
  EXPECT_LT(sim3.translation.rmse, 1e-9);
}

TEST(Ate, ConstantOffsetAndScaleErrorGiveExpectedValues) {
  const Trajectory gt = testing::MakeLoop(20.0, 15.0);
  const Eigen::Vector3d offset(0.3, -0.4, 0.0);  // 0.5 m
  const Association shifted = PairWith(
      gt, [&](std::size_t, const SE3& g) { return SE3(g.so3(), g.translation() + offset); });
  const AteResult none = ComputeAte(shifted, AlignmentMode::kNone);
  EXPECT_NEAR(none.translation.rmse, 0.5, 1e-12);
  EXPECT_NEAR(none.translation.std, 0.0, 1e-12);
  EXPECT_LT(ComputeAte(shifted, AlignmentMode::kSE3).translation.rmse, 1e-9);

  // Scaled by k about the centroid: rigid alignment cannot absorb it (the cross-covariance
  // is k * the gt covariance, symmetric, so R = I), every error is |k - 1| * distance to the
  // centroid; Sim3 removes it.
  Eigen::Vector3d mu = Eigen::Vector3d::Zero();
  for (const auto& p : gt) mu += p.T_w_c.translation();
  mu /= static_cast<double>(gt.size());
  double ms = 0.0;
  for (const auto& p : gt) ms += (p.T_w_c.translation() - mu).squaredNorm();
  const double rms_radius = std::sqrt(ms / gt.size());
  const double k = 1.2;
  const Association scaled = PairWith(
      gt, [&](std::size_t, const SE3& g) { return SE3(g.so3(), mu + k * (g.translation() - mu)); });
  const AteResult se3 = ComputeAte(scaled, AlignmentMode::kSE3);
  EXPECT_NEAR(se3.translation.rmse, (k - 1.0) * rms_radius, 1e-9);
  EXPECT_GT(se3.translation.rmse, 0.1);
  const AteResult sim3 = ComputeAte(scaled, AlignmentMode::kSim3);
  EXPECT_NEAR(sim3.alignment.scale, 1.0 / k, 1e-9);
  EXPECT_LT(sim3.translation.rmse, 1e-9);
}

TEST(Ate, IsotropicNoiseGivesSigmaSqrt3) {
  std::mt19937 rng(42);
  const double sigma = 0.05;
  std::normal_distribution<double> noise(0.0, sigma);
  const Trajectory gt = testing::MakeLoop(100.0, 60.0);  // 6001 poses
  const SE3 T = testing::RandomSE3(rng);
  const Association a = PairWith(gt, [&](std::size_t, const SE3& g) {
    return T * SE3(g.so3(), g.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  });
  const AteResult r = ComputeAte(a, AlignmentMode::kSE3);
  // Relative standard error of the RMSE ~ 1 / sqrt(6 n) ~ 0.5 %; 3 % is > 5 sigma.
  EXPECT_NEAR(r.translation.rmse / (sigma * std::sqrt(3.0)), 1.0, 0.03);
  // The mean of a chi(3) variable: sigma * 2 sqrt(2 / pi).
  EXPECT_NEAR(r.translation.mean / (sigma * 2.0 * std::sqrt(2.0 / M_PI)), 1.0, 0.03);
}

TEST(Rpe, ConstantPerStepScaleErrorGivesExpectedDrift) {
  const double e = 0.03;                    // every step 3 % too long
  const Trajectory gt = StraightLine(201);  // 20 m
  const Association a = PairWith(gt, [&](std::size_t i, const SE3& g) {
    return SE3(g.so3(), Eigen::Vector3d(0.1 * (1.0 + e) * i, 0.0, 1.0));
  });
  const RpeFramesResult f1 = ComputeRpeFrames(a.est, a.gt, 1);
  EXPECT_EQ(f1.translation.count, 200u);
  EXPECT_NEAR(f1.translation.rmse, e * 0.1, 1e-9);
  EXPECT_NEAR(f1.rotation_deg.rmse, 0.0, 1e-6);
  const RpeFramesResult f10 = ComputeRpeFrames(a.est, a.gt, 10);
  EXPECT_EQ(f10.translation.count, 191u);
  EXPECT_NEAR(f10.translation.rmse, e * 1.0, 1e-9);

  const std::vector<RpeDistanceResult> d = ComputeRpeDistance(a.est, a.gt, {1.0, 2.0, 5.0, 50.0});
  ASSERT_EQ(d.size(), 4u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(d[k].segments, 0u);
    EXPECT_NEAR(d[k].translation_pct, 100.0 * e, 1e-6) << "L = " << d[k].length;
    EXPECT_NEAR(d[k].rotation_deg_per_m, 0.0, 1e-6);
  }
  EXPECT_EQ(d[0].segments, 191u);  // starts 0..190 reach 1 m
  EXPECT_EQ(d[2].segments, 151u);
  EXPECT_EQ(d[3].segments, 0u);  // longer than the 20 m path: skipped
  EXPECT_EQ(d[3].translation_pct, 0.0);

  // Through the full evaluation: rigid alignment keeps the drift, Sim3 removes it.
  EvaluationOptions opt;
  opt.rpe_lengths = {1.0, 5.0};
  const EvaluationResult se3 = EvaluateTrajectory(a.est, gt, {}, opt);
  EXPECT_NEAR(se3.rpe_distance[0].translation_pct, 100.0 * e, 1e-6);
  opt.alignment = AlignmentMode::kSim3;
  const EvaluationResult sim3 = EvaluateTrajectory(a.est, gt, {}, opt);
  EXPECT_NEAR(sim3.ate.alignment.scale, 1.0 / (1.0 + e), 1e-9);
  EXPECT_NEAR(sim3.rpe_distance[0].translation_pct, 0.0, 1e-6);
}

TEST(Rpe, ConstantYawRateGivesExpectedRotationDrift) {
  const double k = 0.02;  // rad per metre
  Trajectory gt;
  for (int i = 0; i < 101; ++i) {
    StampedPose p;
    p.t = i * 0.1;
    p.T_w_c = SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.1 * i, 0, 0));
    gt.push_back(p);
  }
  const Association a = PairWith(gt, [&](std::size_t i, const SE3& g) {
    return SE3(ExpSO3(Eigen::Vector3d(0, 0, k * 0.1 * i)), g.translation());
  });
  const std::vector<RpeDistanceResult> d = ComputeRpeDistance(a.est, a.gt, {2.0});
  EXPECT_NEAR(d[0].rotation_deg_per_m, k * 180.0 / M_PI, 1e-9);
}

TEST(Coverage, MissingFrames) {
  std::vector<double> frames;
  Trajectory est;
  for (int i = 0; i < 100; ++i) {
    frames.push_back(5.0 + 0.05 * i);
    if (i % 10 == 3) continue;  // 10 frames lost
    StampedPose p;
    p.t = 5.0 + 0.05 * i + 0.001;
    est.push_back(p);
  }
  const CoverageResult c = ComputeCoverage(frames, est, 0.02);
  EXPECT_EQ(c.frames, 100u);
  EXPECT_EQ(c.covered, 90u);
  EXPECT_NEAR(c.ratio, 0.9, 1e-12);

  // Each estimate covers one frame at most: 20 Hz estimates over 200 Hz stamps ~ 0.1.
  std::vector<double> dense;
  for (int i = 0; i < 1000; ++i) dense.push_back(5.0 + 0.005 * i);
  const CoverageResult d = ComputeCoverage(dense, est, 0.02);
  EXPECT_EQ(d.covered, 90u);
  EXPECT_NEAR(d.ratio, 0.09, 1e-12);

  EXPECT_EQ(ComputeCoverage({}, est, 0.02).ratio, 0.0);
  EXPECT_EQ(ComputeCoverage(frames, {}, 0.02).covered, 0u);

  // Through the evaluation: default frame stamps are the ground-truth stamps.
  Trajectory gt;
  for (double t : frames) {
    StampedPose p;
    p.t = t;
    p.T_w_c.translation() = Eigen::Vector3d(t, 0, 0);
    gt.push_back(p);
  }
  EXPECT_NEAR(EvaluateTrajectory(est, gt, {}).coverage.ratio, 0.9, 1e-12);
  EXPECT_NEAR(EvaluateTrajectory(est, gt, dense).coverage.ratio, 0.09, 1e-12);
}

TEST(Evaluation, DegenerateInputs) {
  const Trajectory gt = testing::MakeLoop(20.0, 5.0);
  EXPECT_THROW(EvaluateTrajectory({}, gt, {}), InputError);
  EXPECT_THROW(EvaluateTrajectory(gt, {}, {}), InputError);

  // No time overlap: the message shows both spans.
  Trajectory late = gt;
  for (auto& p : late) p.t += 1000.0;
  try {
    EvaluateTrajectory(late, gt, {});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1100.000"), std::string::npos) << e.what();
  }

  // One and two poses: finite results, RPE rows without samples, Sim3 not computed for one.
  for (std::size_t n : {1u, 2u}) {
    const Trajectory est(gt.begin(), gt.begin() + n);
    const EvaluationResult r = EvaluateTrajectory(est, gt, {});
    EXPECT_EQ(r.association.size(), n);
    EXPECT_LT(r.ate.translation.rmse, 1e-9);
    EXPECT_EQ(r.rpe_frames[1].translation.count, 0u);  // delta 10
    EXPECT_EQ(r.sim3_valid, n == 2);
    const std::string json = FormatEvaluationJson(r, "tiny");
    EXPECT_EQ(json.find("nan"), std::string::npos) << json;
    EXPECT_EQ(json.find("inf"), std::string::npos) << json;
    const std::string table = FormatEvaluationTable(r, "tiny");
    EXPECT_EQ(table.find("nan"), std::string::npos) << table;
  }

  // All estimate positions identical (a stuck tracker): SE3 fine, Sim3 reported as n/a,
  // and an error when Sim3 is the requested alignment.
  Trajectory stuck = gt;
  for (auto& p : stuck) p.T_w_c.translation() = Eigen::Vector3d(1, 2, 3);
  const EvaluationResult r = EvaluateTrajectory(stuck, gt, {});
  EXPECT_TRUE(r.se3_valid);
  EXPECT_FALSE(r.sim3_valid);
  EXPECT_NE(r.sim3_note.find("identical"), std::string::npos);
  EXPECT_TRUE(std::isfinite(r.ate.translation.rmse));
  EXPECT_GT(r.ate.translation.rmse, 0.1);
  EXPECT_NE(FormatEvaluationJson(r, "stuck").find("\"ate_sim3\": null"), std::string::npos);
  EvaluationOptions sim3;
  sim3.alignment = AlignmentMode::kSim3;
  EXPECT_THROW(EvaluateTrajectory(stuck, gt, {}, sim3), InputError);

  // Bad options name the key.
  EvaluationOptions bad;
  bad.rpe_frame_deltas = {0};
  EXPECT_THROW(EvaluateTrajectory(gt, gt, {}, bad), ConfigError);
  bad = EvaluationOptions{};
  bad.rpe_lengths = {-1.0};
  EXPECT_THROW(EvaluateTrajectory(gt, gt, {}, bad), ConfigError);
}

TEST(Evaluation, ReportsContainTheNumbers) {
  const Trajectory gt = testing::MakeLoop(20.0, 30.0);
  const Trajectory est = testing::MakeLoop(20.0, 30.0);
  const EvaluationResult r = EvaluateTrajectory(est, gt, {});
  const std::string table = FormatEvaluationTable(r, "loop");
  for (const char* key : {"loop", "ATE SE3", "ATE Sim3", "RPE", "drift", "coverage"}) {
    EXPECT_NE(table.find(key), std::string::npos) << key << "\n" << table;
  }
  const std::string json = FormatEvaluationJson(r, "lo\"op");
  EXPECT_NE(json.find("\"name\": \"lo\\\"op\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"rpe_distance\""), std::string::npos);
  EXPECT_EQ(json.front(), '{');
}

}  // namespace
}  // namespace eval
}  // namespace pl_slam
