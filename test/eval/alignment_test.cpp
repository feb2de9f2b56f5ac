#include "pl_slam/eval/alignment.h"

#include <gtest/gtest.h>

#include <random>

#include "eval_test_util.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {
namespace {

Points3d RandomPoints(std::mt19937& rng, int n, double spread) {
  std::normal_distribution<double> g(0.0, spread);
  Points3d pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(g(rng), g(rng), g(rng));
  return pts;
}

double RotationDiffDeg(const SE3& a, const SE3& b) {
  return LogSO3(a.rotation().transpose() * b.rotation()).norm() * 180.0 / M_PI;
}

TEST(Umeyama, RecoversRandomSE3ExactlyOnNoiseFreeData) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = testing::RandomSE3(rng);
    const Points3d src = RandomPoints(rng, 50, 2.0);
    Points3d dst;
    for (const auto& p : src) dst.push_back(T * p);
    const Alignment a = UmeyamaAlignment(src, dst, false);
    EXPECT_EQ(a.mode, AlignmentMode::kSE3);
    EXPECT_DOUBLE_EQ(a.scale, 1.0);
    EXPECT_LT((a.T_gt_est.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    EXPECT_GT(a.T_gt_est.rotation().determinant(), 0.0);
  }
}

TEST(Umeyama, RecoversSim3WithScaleExactly) {
  std::mt19937 rng(11);
  const double s = 2.5;
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = testing::RandomSE3(rng);
    const Points3d src = RandomPoints(rng, 40, 1.0);
    Points3d dst;
    for (const auto& p : src) dst.push_back(s * (T.so3() * p) + T.translation());
    const Alignment a = UmeyamaAlignment(src, dst, true);
    EXPECT_EQ(a.mode, AlignmentMode::kSim3);
    EXPECT_NEAR(a.scale, s, 1e-9);
    EXPECT_LT((a.T_gt_est.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    for (std::size_t i = 0; i < src.size(); ++i) EXPECT_LT((a.Apply(src[i]) - dst[i]).norm(), 1e-9);
  }
}

TEST(Umeyama, WithinStatisticalBoundUnderGaussianNoise) {
  // 500 points with 1 m spread, 1 cm noise: the rotation error of the least-squares fit is
  // about sigma / (spread * sqrt(n)) rad = 2.6e-2 deg, translation about sigma / sqrt(n).
  std::mt19937 rng(3);
  const double sigma = 0.01;
  const int n = 500;
  std::normal_distribution<double> noise(0.0, sigma);
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 T = testing::RandomSE3(rng);
    const Points3d src = RandomPoints(rng, n, 1.0);
    Points3d dst;
    for (const auto& p : src)
      dst.push_back(T * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    const Alignment a = UmeyamaAlignment(src, dst, false);
    EXPECT_LT(RotationDiffDeg(a.T_gt_est, T), 0.15);  // ~5 sigma of the estimator
    // The translation error is dominated by the centroid noise, sigma * sqrt(3 / n).
    const Eigen::Vector3d centroid_error =
        a.T_gt_est * Eigen::Vector3d::Zero() - T * Eigen::Vector3d::Zero();
    EXPECT_LT(centroid_error.norm(), 0.006);

    Points3d dst_s;
    for (const auto& p : src) {
      dst_s.push_back(2.5 * (T.so3() * p) + T.translation() +
                      Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
    const Alignment b = UmeyamaAlignment(src, dst_s, true);
    EXPECT_NEAR(b.scale, 2.5, 0.005);  // std of the scale ~ sigma / (spread sqrt(3n)) ~ 3e-4
    EXPECT_LT(RotationDiffDeg(b.T_gt_est, T), 0.15);
  }
}

TEST(Umeyama, HandlesReflectionCaseWithProperRotation) {
  // A 3-D point set and its mirror image (x -> -x): the cross-covariance is about
  // diag(-9, 4, 1), whose unconstrained fit is the reflection diag(-1, 1, 1). The best proper
  // rotation also flips the axis of least spread (z): R = diag(-1, 1, -1), pi about y.
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0.0, 1.0);
  Points3d src;
  for (int i = 0; i < 200; ++i) src.emplace_back(3.0 * g(rng), 2.0 * g(rng), 1.0 * g(rng));
  Points3d dst;
  for (const auto& p : src) dst.emplace_back(-p.x(), p.y(), p.z());
  const Alignment a = UmeyamaAlignment(src, dst, false);
  const Eigen::Matrix3d R = a.T_gt_est.rotation();
  EXPECT_NEAR(R.determinant(), 1.0, 1e-9);
  EXPECT_TRUE(a.T_gt_est.IsFinite());
  // Near diag(-1, 1, -1): exactly so for an exactly diagonal sample covariance.
  EXPECT_LT((R - Eigen::Vector3d(-1, 1, -1).asDiagonal().toDenseMatrix()).cwiseAbs().maxCoeff(),
            0.2);
  // A planar mirror is a proper rotation in 3-D (pi about the in-plane axis): exact fit.
  Points3d flat = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 0.5, 0}};
  Points3d flat_mirror;
  for (const auto& p : flat) flat_mirror.emplace_back(p.x(), -p.y(), p.z());
  const Alignment b = UmeyamaAlignment(flat, flat_mirror, false);
  for (std::size_t i = 0; i < flat.size(); ++i) {
    EXPECT_LT((b.Apply(flat[i]) - flat_mirror[i]).norm(), 1e-9);
  }
}

TEST(Umeyama, DegenerateInputs) {
  EXPECT_THROW(UmeyamaAlignment({}, {}, false), InputError);
  EXPECT_THROW(UmeyamaAlignment({{0, 0, 0}}, {}, false), InputError);
  // One point: pure translation.
  const Alignment one = UmeyamaAlignment({{1, 2, 3}}, {{4, 6, 8}}, false);
  EXPECT_LT(one.T_gt_est.RotationAngle(), 1e-12);
  EXPECT_LT((one.T_gt_est.translation() - Eigen::Vector3d(3, 4, 5)).norm(), 1e-12);
  // Two points: a valid rotation mapping one onto the other exactly.
  const Points3d src2 = {{0, 0, 0}, {1, 0, 0}};
  const Points3d dst2 = {{5, 5, 5}, {5, 6, 5}};
  const Alignment two = UmeyamaAlignment(src2, dst2, false);
  EXPECT_TRUE(two.T_gt_est.IsFinite());
  for (int i = 0; i < 2; ++i) EXPECT_LT((two.Apply(src2[i]) - dst2[i]).norm(), 1e-9);
  // Identical estimate positions: SE3 fine (translation only), Sim3 scale undefined.
  const Points3d same = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  const Points3d spread = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const Alignment se3 = UmeyamaAlignment(same, spread, false);
  EXPECT_TRUE(se3.T_gt_est.IsFinite());
  EXPECT_THROW(UmeyamaAlignment(same, spread, true), InputError);
  EXPECT_THROW(UmeyamaAlignment(spread, same, true), InputError);
}

TEST(Alignment, FirstPoseAndNone) {
  std::mt19937 rng(5);
  Association assoc;
  assoc.est = testing::MakeLoop(10.0, 5.0);
  const SE3 T = testing::RandomSE3(rng);
  for (const auto& p : assoc.est) {
    StampedPose q = p;
    q.T_w_c = T * p.T_w_c;
    assoc.gt.push_back(q);
  }
  const Alignment first = AlignTrajectories(assoc, AlignmentMode::kFirstPose);
  EXPECT_LT((first.T_gt_est.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  const Alignment none = AlignTrajectories(assoc, AlignmentMode::kNone);
  EXPECT_LT((none.T_gt_est.matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(),
            0.0 + 1e-15);
  EXPECT_THROW(AlignTrajectories(Association{}, AlignmentMode::kSE3), InputError);
}

TEST(Alignment, ParseModes) {
  EXPECT_EQ(ParseAlignmentMode("SE3"), AlignmentMode::kSE3);
  EXPECT_EQ(ParseAlignmentMode("sim3"), AlignmentMode::kSim3);
  EXPECT_EQ(ParseAlignmentMode("none"), AlignmentMode::kNone);
  EXPECT_EQ(ParseAlignmentMode("first-pose"), AlignmentMode::kFirstPose);
  EXPECT_THROW(ParseAlignmentMode("affine"), ConfigError);
  for (auto m : {AlignmentMode::kNone, AlignmentMode::kFirstPose, AlignmentMode::kSE3,
                 AlignmentMode::kSim3}) {
    EXPECT_EQ(ParseAlignmentMode(AlignmentModeName(m)), m);
  }
}

}  // namespace
}  // namespace eval
}  // namespace pl_slam
