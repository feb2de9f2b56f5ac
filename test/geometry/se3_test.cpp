#include <random>

#include <gtest/gtest.h>

#include "pl_slam/geometry/se3.h"

namespace pl_slam {
namespace {

Vector6d RandomTwist(std::mt19937& rng, double rot_scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi(i) = n(rng);
  for (int i = 3; i < 6; ++i) xi(i) = rot_scale * n(rng);
  return xi;
}

TEST(SE3, ExpLogRoundTripOverTheRotationRange) {
  std::mt19937 rng(7);
  for (double scale : {1e-9, 1e-5, 0.1, 1.0}) {
    for (int k = 0; k < 50; ++k) {
      Vector6d xi = RandomTwist(rng, scale);
      if (xi.tail<3>().norm() > 3.0) xi.tail<3>() *= 3.0 / xi.tail<3>().norm();
      const Vector6d back = SE3::Exp(xi).Log();
      EXPECT_LT((back - xi).norm(), 1e-9 * std::max(1.0, xi.norm())) << xi.transpose();
    }
  }
}

TEST(SE3, LogNearPiIsStable) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  const double angle = M_PI - 1e-7;
  const Eigen::Vector3d phi = LogSO3(ExpSO3(axis * angle));
  EXPECT_NEAR(phi.norm(), angle, 1e-6);
  EXPECT_NEAR(std::abs(phi.normalized().dot(axis)), 1.0, 1e-9);
}

TEST(SE3, CompositionInverseAndPointAction) {
  std::mt19937 rng(3);
  const SE3 A = SE3::Exp(RandomTwist(rng, 0.5));
  const SE3 B = SE3::Exp(RandomTwist(rng, 0.5));
  const Eigen::Vector3d p(0.3, -1.2, 2.5);
  EXPECT_LT(((A * B) * p - A * (B * p)).norm(), 1e-12);
  EXPECT_LT((A.inverse() * (A * p) - p).norm(), 1e-12);
  EXPECT_LT(((A * B).matrix() - A.matrix() * B.matrix()).norm(), 1e-12);
  EXPECT_LT((SE3::FromMatrix(A.matrix()).matrix() - A.matrix()).norm(), 1e-12);
}

TEST(SE3, AdjointMovesTwistsAcross) {
  std::mt19937 rng(11);
  const SE3 T = SE3::Exp(RandomTwist(rng, 0.7));
  const Vector6d xi = 1e-3 * RandomTwist(rng, 1.0);
  const SE3 lhs = T * SE3::Exp(xi) * T.inverse();
  const SE3 rhs = SE3::Exp(T.Adjoint() * xi);
  EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 1e-12);
}

TEST(SE3, LeftJacobianMatchesFiniteDifferences) {
  // Exp(phi + d) ~= Exp(J_l(phi) d) Exp(phi)
  const Eigen::Vector3d phi(0.4, -0.3, 0.9);
  const Eigen::Matrix3d J = LeftJacobianSO3(phi);
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(i) = 1e-6;
    const Eigen::Vector3d numeric = LogSO3(ExpSO3(phi + d) * ExpSO3(phi).transpose()) / 1e-6;
    EXPECT_LT((numeric - J.col(i)).norm(), 1e-5) << "column " << i;
  }
  EXPECT_LT((LeftJacobianInvSO3(phi) * J - Eigen::Matrix3d::Identity()).norm(), 1e-10);
}

TEST(SE3, RotationAngleAndFiniteness) {
  const SE3 T(ExpSO3(Eigen::Vector3d(0, 0, 0.5)), Eigen::Vector3d(1, 2, 3));
  EXPECT_NEAR(T.RotationAngle(), 0.5, 1e-12);
  EXPECT_TRUE(T.IsFinite());
  SE3 bad = T;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(bad.IsFinite());
}

}  // namespace
}  // namespace pl_slam
