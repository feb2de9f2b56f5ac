// Choosing between two pose estimates by their covariances (PreferUnlessWeaker): the second is
// taken wherever it is at least as certain, the first kept along the second's weak directions,
// and bad input is refused.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Matrix6d Diagonal(double sd_m, double sd_rad) {
  Matrix6d c = Matrix6d::Zero();
  c.diagonal() << sd_m * sd_m, sd_m * sd_m, sd_m * sd_m, sd_rad * sd_rad, sd_rad * sd_rad,
      sd_rad * sd_rad;
  return c;
}

SE3 Pose(double x, double y, double z, double rx, double ry, double rz) {
  Vector6d xi;
  xi << x, y, z, rx, ry, rz;
  return SE3::Exp(xi);
}

TEST(PreferUnlessWeaker, TheSecondEstimateIsTakenWhereItIsAtLeastAsCertain) {
  const SE3 a = Pose(1.0, 0.2, -0.3, 0.1, 0.0, 0.05);
  Vector6d step;
  step << 0.004, -0.002, 0.001, 0.002, -0.001, 0.003;
  const SE3 b = SE3::Exp(step) * a;
  for (const double ratio : {1.0, 0.25}) {  // as certain as a, then twice as certain
    const Matrix6d cov_a = Diagonal(0.002, 0.1 * kDeg);
    const Matrix6d cov_b = ratio * cov_a;
    SE3 kept;
    Matrix6d cov;
    ASSERT_TRUE(PreferUnlessWeaker(a, cov_a, b, cov_b, &kept, &cov));
    EXPECT_TRUE(kept.matrix().isApprox(b.matrix(), 1e-9)) << ratio;
    EXPECT_LT((cov - cov_b).norm(), 1e-12 * cov_b.norm() + 1e-18) << ratio;
  }
}

TEST(PreferUnlessWeaker, AWeakDirectionOfTheSecondKeepsTheFirst) {
  // b: a few clustered features, whose sideways shift and turn trade off (strongly correlated,
  // centimetres and a degree along that direction); elsewhere as certain as a.
  const SE3 a = Pose(0.3, -0.1, 2.0, 0.0, 0.2, 0.0);
  const Matrix6d cov_a = Diagonal(0.001, 0.02 * kDeg);
  Vector6d weak;  // 1 cm sideways with 0.57 deg about the vertical axis
  weak << 0.01, 0.0, 0.0, 0.0, 0.01, 0.0;
  const Matrix6d cov_b = cov_a + 4.0 * weak * weak.transpose();
  // b lies 3.5 cm and 2 deg off a along its weak direction, and 2 mm off along z.
  Vector6d offset = 3.5 * weak;
  offset(2) = 0.002;
  const SE3 b = SE3::Exp(offset) * a;
  SE3 kept;
  Matrix6d cov;
  ASSERT_TRUE(PreferUnlessWeaker(a, cov_a, b, cov_b, &kept, &cov));
  const Vector6d from_a = (kept * a.inverse()).Log();
  // Along the weak direction the result stays within a millimetre of a...
  EXPECT_LT(std::abs(from_a(0)), 0.001);
  EXPECT_LT(std::abs(from_a(4)), 0.05 * kDeg);
  // ...while along z, where b is as certain as a, it is b's.
  EXPECT_NEAR(from_a(2), 0.002, 1e-5);
}

TEST(PreferUnlessWeaker, AlongADirectionWithLambdaTimesTheVarianceItMovesOneLambdaOfTheWay) {
  const SE3 a = Pose(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
  const Matrix6d cov_a = Diagonal(0.001, 0.01 * kDeg);
  Matrix6d cov_b = cov_a;
  cov_b(1, 1) *= 4.0;  // y: lambda = 4
  const SE3 b = Pose(0.0, 0.008, 0.0, 0.0, 0.0, 0.0) * a;
  SE3 kept;
  Matrix6d cov;
  ASSERT_TRUE(PreferUnlessWeaker(a, cov_a, b, cov_b, &kept, &cov));
  EXPECT_NEAR((kept * a.inverse()).Log()(1), 0.002, 1e-6);
  // Variance along y: (1 - 1/4)^2 cov_a + (1/4)^2 cov_b = (9/16 + 1/4) cov_a.
  EXPECT_NEAR(cov(1, 1), 13.0 / 16.0 * cov_a(1, 1), 1e-12);
}

TEST(PreferUnlessWeaker, BadInputIsRefusedAndLeavesTheOutputs) {
  const SE3 a = Pose(0.1, 0.0, 0.0, 0.0, 0.0, 0.0);
  const Matrix6d cov = Diagonal(0.001, 0.01);
  const SE3 untouched = Pose(9.0, 9.0, 9.0, 0.0, 0.0, 0.0);
  SE3 kept = untouched;
  Matrix6d kept_cov = Matrix6d::Identity();
  Matrix6d nan_cov = cov;
  nan_cov(2, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(PreferUnlessWeaker(a, nan_cov, a, cov, &kept, &kept_cov));
  EXPECT_FALSE(PreferUnlessWeaker(a, cov, a, nan_cov, &kept, &kept_cov));
  EXPECT_FALSE(PreferUnlessWeaker(a, Matrix6d::Zero(), a, cov, &kept, &kept_cov));
  EXPECT_FALSE(PreferUnlessWeaker(a, -cov, a, cov, &kept, &kept_cov));
  EXPECT_TRUE(kept.matrix().isApprox(untouched.matrix()));
  EXPECT_TRUE(kept_cov.isIdentity());
}

}  // namespace
}  // namespace pl_slam
