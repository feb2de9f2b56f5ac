// Two-view triangulation of segments that stereo cannot measure (along the image rows).
#include <gtest/gtest.h>

#include <cmath>

#include "../../src/mapping/mapping_steps.h"
#include "pl_slam/features/line_features.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A skirting board 1 m below the camera and 4 m ahead, 2 m long, parallel to the image rows.
const Eigen::Vector3d kA(-1.0, 1.0, 4.0), kB(1.0, 1.0, 4.0);

LineFeature Seen(const StereoCamera& cam, const SE3& T_w_c, const Eigen::Vector3d& P,
                 const Eigen::Vector3d& Q) {
  const SE3 T_c_w = T_w_c.inverse();
  return MakeLineFeature(cam.Project(T_c_w * P), cam.Project(T_c_w * Q));
}

SE3 Forward(double z) { return SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, z)); }

TEST(TriangulateLine, AHorizontalSegmentFromForwardMotion) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  const SE3 T_w_a = Forward(0.0), T_w_b = Forward(0.8);
  const LineFeature a = Seen(cam, T_w_a, kA, kB), b = Seen(cam, T_w_b, kA, kB);
  ASSERT_LT(std::abs(a.s.y() - a.e.y()), 1e-9) << "along the rows: no stereo depth";
  Eigen::Vector3d P, Q;
  ASSERT_TRUE(mapping::TriangulateLine(cam, T_w_a, a, T_w_b, b, 2.0 * kPi / 180.0, 100.0, &P, &Q));
  EXPECT_LT((P - kA).norm(), 1e-6);
  EXPECT_LT((Q - kB).norm(), 1e-6);
}

TEST(TriangulateLine, TooLittleParallaxIsRefused) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  // 5 cm forward: the two planes meet at about 0.2 degrees.
  const SE3 T_w_a = Forward(0.0), T_w_b = Forward(0.05);
  Eigen::Vector3d P, Q;
  EXPECT_FALSE(mapping::TriangulateLine(cam, T_w_a, Seen(cam, T_w_a, kA, kB), T_w_b,
                                        Seen(cam, T_w_b, kA, kB), 2.0 * kPi / 180.0, 100.0, &P,
                                        &Q));
  // With the bound lowered below the angle it is accepted (the test of the bound, not luck).
  EXPECT_TRUE(mapping::TriangulateLine(cam, T_w_a, Seen(cam, T_w_a, kA, kB), T_w_b,
                                       Seen(cam, T_w_b, kA, kB), 0.1 * kPi / 180.0, 100.0, &P, &Q));
}

TEST(TriangulateLine, DisjointStretchesAndFarResultsAreRefused) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  const SE3 T_w_a = Forward(0.0), T_w_b = Forward(0.8);
  const Eigen::Vector3d mid = 0.5 * (kA + kB);
  Eigen::Vector3d P, Q;
  // View a saw the left half, view b the right half: not the same stretch of line.
  EXPECT_FALSE(mapping::TriangulateLine(
      cam, T_w_a, Seen(cam, T_w_a, kA, mid - Eigen::Vector3d(0.3, 0, 0)), T_w_b,
      Seen(cam, T_w_b, mid + Eigen::Vector3d(0.3, 0, 0), kB), 2.0 * kPi / 180.0, 100.0, &P, &Q));
  // Beyond the depth bound.
  EXPECT_FALSE(mapping::TriangulateLine(cam, T_w_a, Seen(cam, T_w_a, kA, kB), T_w_b,
                                        Seen(cam, T_w_b, kA, kB), 2.0 * kPi / 180.0, 3.0, &P, &Q));
}

}  // namespace
}  // namespace pl_slam
