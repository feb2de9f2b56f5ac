// Consensus stage: the minimal solvers recover exact motions and refuse degenerate sets; the
// RANSAC recovers a known motion and its inliers at known outlier ratios, from points, from
// segments and from both, whatever the prior; and the robust refinement started from it stays
// accurate where starting from a wrong prior over everything does not.
#include "pl_slam/tracking/motion_consensus.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

StereoCamera TestCamera() { return testing_util::EurocSizedCamera(); }

SE3 TrueMotion() {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, -0.3).normalized();
  return SE3(ExpSO3(4.0 * kDeg * axis), Eigen::Vector3d(0.05, -0.02, 0.12));
}

double TranslationError(const SE3& a, const SE3& b) {
  return (a.inverse() * b).translation().norm();
}
double RotationErrorDeg(const SE3& a, const SE3& b) {
  return (a.inverse() * b).RotationAngle() / kDeg;
}

// Correspondences between two stereo frames under T_cur_prev, a share of them replaced by
// garbage; the current 3D positions carry stereo depth noise as a disparity error would.
struct Data {
  PointMatches3D2D points;
  LineMatches3D2D lines;
  Points3D points_cur, lines_cur_P, lines_cur_Q;
  std::vector<uint8_t> point_outlier, line_outlier;
};

Eigen::Vector3d StereoNoisy(const StereoCamera& cam, const Eigen::Vector3d& X, double sigma_d,
                            std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, sigma_d);
  const double d = cam.fx * cam.baseline / X.z() + n(*rng);
  const double z = cam.fx * cam.baseline / std::max(d, 1.0);
  return X * (z / X.z());
}

Data MakeData(const SE3& T, int num_points, int num_lines, double outlier_fraction, uint32_t seed) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), depth(1.5, 8.0), unit(0.0, 1.0);
  std::normal_distribution<double> px(0.0, 0.5);
  auto in_view = [&](double z) {
    const double x = u(rng) * 0.7 * z, y = u(rng) * 0.45 * z;
    return Eigen::Vector3d(x, y, z);
  };
  Data d;
  while (static_cast<int>(d.points.size()) < num_points) {
    const Eigen::Vector3d P = in_view(depth(rng));
    const Eigen::Vector3d X = T * P;
    if (X.z() < 0.5 || !cam.InImage(cam.Project(X), 5.0)) continue;
    PointMatch3D2D m;
    m.P_prev = StereoNoisy(cam, P, 0.3, &rng);
    m.uv_cur = cam.Project(X) + Eigen::Vector2d(px(rng), px(rng));
    Eigen::Vector3d cur = StereoNoisy(cam, X, 0.3, &rng);
    const bool outlier = unit(rng) < outlier_fraction;
    if (outlier) {
      // A mismatch: the observation and its triangulation belong to another point.
      const Eigen::Vector3d other = in_view(depth(rng));
      m.uv_cur = cam.Project(other);
      cur = other;
    }
    d.points.push_back(m);
    d.points_cur.push_back(cur);
    d.point_outlier.push_back(outlier);
  }
  while (static_cast<int>(d.lines.size()) < num_lines) {
    const Eigen::Vector3d P = in_view(depth(rng));
    const Eigen::Vector3d Q = P + 0.8 * Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng));
    const Eigen::Vector3d XP = T * P, XQ = T * Q;
    if (XP.z() < 0.5 || XQ.z() < 0.5 || !cam.InImage(cam.Project(XP), 5.0) ||
        !cam.InImage(cam.Project(XQ), 5.0) || (cam.Project(XP) - cam.Project(XQ)).norm() < 30)
      continue;
    LineMatch3D2D m;
    m.P_prev = StereoNoisy(cam, P, 0.3, &rng);
    m.Q_prev = StereoNoisy(cam, Q, 0.3, &rng);
    // The current detection covers another stretch of the same 3D line.
    const double a = 0.2 * unit(rng), b = 1.0 - 0.2 * unit(rng);
    Eigen::Vector3d cP = T * (P + a * (Q - P)), cQ = T * (P + b * (Q - P));
    const bool outlier = unit(rng) < outlier_fraction;
    if (outlier) {
      cP = in_view(depth(rng));
      cQ = cP + 0.8 * Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng));
    }
    const Eigen::Vector2d s = cam.Project(cP) + Eigen::Vector2d(px(rng), px(rng));
    const Eigen::Vector2d e = cam.Project(cQ) + Eigen::Vector2d(px(rng), px(rng));
    Eigen::Vector3d l = Eigen::Vector3d(s.x(), s.y(), 1.0).cross(Eigen::Vector3d(e.x(), e.y(), 1));
    m.l_cur = l / l.head<2>().norm();
    d.lines.push_back(m);
    d.lines_cur_P.push_back(cP.z() > 0.5 ? StereoNoisy(cam, cP, 0.3, &rng) : cP);
    d.lines_cur_Q.push_back(cQ.z() > 0.5 ? StereoNoisy(cam, cQ, 0.3, &rng) : cQ);
    d.line_outlier.push_back(outlier);
  }
  return d;
}

TEST(RigidFromPointsTest, RecoversAnExactMotionAndRefusesCollinearPoints) {
  const SE3 T = TrueMotion();
  Points3D prev{{0.1, 0.2, 2.0}, {-0.5, 0.1, 3.0}, {0.3, -0.4, 4.0}}, cur;
  for (const auto& p : prev) cur.push_back(T * p);
  SE3 est;
  ASSERT_TRUE(RigidFromPoints(prev, cur, &est));
  EXPECT_LT(TranslationError(est, T), 1e-9);
  EXPECT_LT(RotationErrorDeg(est, T), 1e-7);
  Points3D line_prev{{0, 0, 2}, {0, 0, 3}, {0, 0, 4}}, line_cur;
  for (const auto& p : line_prev) line_cur.push_back(T * p);
  EXPECT_FALSE(RigidFromPoints(line_prev, line_cur, &est));
}

TEST(RigidFromLinesTest, RecoversAnExactMotionFromOtherStretchesOfTheLines) {
  const SE3 T = TrueMotion();
  const Eigen::Vector3d a1(0.2, 0.1, 3.0), d1 = Eigen::Vector3d(1, 0.1, 0.2).normalized();
  const Eigen::Vector3d a2(-0.4, 0.3, 4.0), d2 = Eigen::Vector3d(0.1, 1, -0.3).normalized();
  const Eigen::Matrix3d R = T.rotation();
  // Points elsewhere on the same lines in the current frame.
  const Eigen::Vector3d b1 = T * (a1 + 0.7 * d1), b2 = T * (a2 - 0.4 * d2);
  SE3 est;
  ASSERT_TRUE(RigidFromLines(a1, d1, a2, d2, b1, R * d1, b2, R * d2, 0.1, &est));
  EXPECT_LT(TranslationError(est, T), 1e-9);
  EXPECT_LT(RotationErrorDeg(est, T), 1e-7);
  // Parallel lines fix no translation along them; a changed angle is no rigid motion.
  EXPECT_FALSE(RigidFromLines(a1, d1, a2, d1, b1, R * d1, b2, R * d1, 0.1, &est));
  const Eigen::Vector3d bent = (R * d2 + 0.5 * R * d1).normalized();
  EXPECT_FALSE(RigidFromLines(a1, d1, a2, d2, b1, R * d1, b2, bent, 0.1, &est));
}

struct Case {
  int points, lines;
  double outliers;
};

class ConsensusOutlierTest : public ::testing::TestWithParam<Case> {};

TEST_P(ConsensusOutlierTest, RecoversTheMotionAndItsInliersFromAWrongPrior) {
  const Case c = GetParam();
  const StereoCamera cam = TestCamera();
  const SE3 T = TrueMotion();
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Data d = MakeData(T, c.points, c.lines, c.outliers, seed);
    // The prior is far off (a sudden stop): the identity and a wrong constant velocity.
    const SE3 wrong(ExpSO3(Eigen::Vector3d(0, 8 * kDeg, 0)), Eigen::Vector3d(0, 0, -0.3));
    const ConsensusResult r =
        FindMotionConsensus(cam, d.points, d.points_cur, d.lines, d.lines_cur_P, d.lines_cur_Q,
                            {wrong, SE3()}, 10, ConsensusOptions());
    ASSERT_TRUE(r.success) << r.failure;
    EXPECT_LT(TranslationError(r.T_cur_prev, T), 0.03);
    EXPECT_LT(RotationErrorDeg(r.T_cur_prev, T), 0.5);
    // Inliers found: nearly every true inlier, and only a few outliers that happen to agree.
    int true_in = 0, found_true = 0, found_false = 0;
    for (std::size_t i = 0; i < d.points.size(); ++i) {
      true_in += !d.point_outlier[i];
      found_true += r.point_inlier[i] && !d.point_outlier[i];
      found_false += r.point_inlier[i] && d.point_outlier[i];
    }
    for (std::size_t i = 0; i < d.lines.size(); ++i) {
      true_in += !d.line_outlier[i];
      found_true += r.line_inlier[i] && !d.line_outlier[i];
      found_false += r.line_inlier[i] && d.line_outlier[i];
    }
    EXPECT_GE(found_true, 0.9 * true_in);
    EXPECT_LE(found_false, 0.05 * (c.points + c.lines) + 2);
    // The refinement from the consensus over the gated correspondences is accurate.
    PointMatches3D2D gp;
    LineMatches3D2D gl;
    for (std::size_t i = 0; i < d.points.size(); ++i)
      if (r.point_gate[i]) gp.push_back(d.points[i]);
    for (std::size_t i = 0; i < d.lines.size(); ++i)
      if (r.line_gate[i]) gl.push_back(d.lines[i]);
    const MotionEstimate est = EstimateMotion(cam, gp, gl, r.T_cur_prev, MotionEstimatorOptions());
    ASSERT_TRUE(est.success) << est.failure;
    EXPECT_LT(TranslationError(est.T_cur_prev, T), 0.01);
    EXPECT_LT(RotationErrorDeg(est.T_cur_prev, T), 0.2);
  }
}

INSTANTIATE_TEST_SUITE_P(OutlierRatios, ConsensusOutlierTest,
                         ::testing::Values(Case{200, 40, 0.0}, Case{200, 40, 0.3},
                                           Case{200, 40, 0.6}, Case{200, 40, 0.8}, Case{0, 60, 0.5},
                                           Case{10, 30, 0.5}));

TEST(ConsensusTest, WithoutItTheRobustFitFromAWrongPriorFailsAtHighOutlierRatios) {
  // What the stage is for: at 70 % outliers the robust Gauss-Newton from a prior far off
  // ends away from the truth on some seeds; from the consensus it never does.
  const StereoCamera cam = TestCamera();
  const SE3 T = TrueMotion();
  const SE3 wrong(ExpSO3(Eigen::Vector3d(0, -10 * kDeg, 0)), Eigen::Vector3d(0.2, 0, -0.3));
  int direct_bad = 0;
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    const Data d = MakeData(T, 150, 30, 0.7, 100 + seed);
    const MotionEstimate direct =
        EstimateMotion(cam, d.points, d.lines, wrong, MotionEstimatorOptions());
    direct_bad += !direct.success || TranslationError(direct.T_cur_prev, T) > 0.01;
    const ConsensusResult r =
        FindMotionConsensus(cam, d.points, d.points_cur, d.lines, d.lines_cur_P, d.lines_cur_Q,
                            {wrong}, 15, ConsensusOptions());
    ASSERT_TRUE(r.success) << r.failure;
    EXPECT_LT(TranslationError(r.T_cur_prev, T), 0.03) << "seed " << seed;
  }
  EXPECT_GT(direct_bad, 0);
}

TEST(ConsensusTest, PureGarbageHasNoConsensus) {
  const StereoCamera cam = TestCamera();
  const Data d = MakeData(TrueMotion(), 100, 20, 1.0, 7);
  const ConsensusResult r = FindMotionConsensus(cam, d.points, d.points_cur, d.lines, d.lines_cur_P,
                                                d.lines_cur_Q, {SE3()}, 15, ConsensusOptions());
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.failure.find("no consensus"), std::string::npos) << r.failure;
}

TEST(ConsensusTest, RefusesBadOptionsAndMismatchedSizes) {
  const StereoCamera cam = TestCamera();
  const Data d = MakeData(TrueMotion(), 20, 0, 0.0, 3);
  ConsensusOptions bad;
  bad.inlier_px = 0.0;
  EXPECT_THROW(FindMotionConsensus(cam, d.points, d.points_cur, d.lines, d.lines_cur_P,
                                   d.lines_cur_Q, {}, 15, bad),
               ConfigError);
  bad = ConsensusOptions();
  bad.gate_px = 1.0;  // below inlier_px
  EXPECT_NE(bad.Validate().find("gate_px"), std::string::npos);
  const Points3D short_cur(d.points_cur.begin(), d.points_cur.end() - 1);
  EXPECT_THROW(FindMotionConsensus(cam, d.points, short_cur, d.lines, d.lines_cur_P, d.lines_cur_Q,
                                   {}, 15, ConsensusOptions()),
               ConfigError);
}

}  // namespace
}  // namespace pl_slam
