// Line residuals measured only where the current image shows the reference segment:
// StereoCamera::SegmentInView and ClipLineToView. What clipping does to the street family's
// visual odometry is measured by the benchmark (docs/BENCHMARKS.md, "Design decisions").
#include <gtest/gtest.h>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {
namespace {

// KITTI-like: 1241x376, camera 1.65 m above the road (y points down).
StereoCamera CarCamera() {
  StereoCamera cam;
  cam.fx = 718.856;
  cam.fy = 718.856;
  cam.cx = 620.0;
  cam.cy = 187.5;
  cam.baseline = 0.54;
  cam.width = 1241;
  cam.height = 376;
  return cam;
}

TEST(SegmentInView, ClipsAtTheImageBorderAndInFrontOfTheCamera) {
  const StereoCamera cam = CarCamera();
  // A road line 1.65 m below and 1.65 m left of the camera, from 2 m to 60 m ahead.
  const Eigen::Vector3d P(-1.65, 1.65, 2.0), Q(-1.65, 1.65, 60.0);
  double t0 = -1.0, t1 = -1.0;
  ASSERT_TRUE(cam.SegmentInView(P, Q, 0.05, &t0, &t1));
  EXPECT_DOUBLE_EQ(t1, 1.0);  // the far end is in view
  // The near end enters the image at its bottom row: z = fy * 1.65 / (height - 1 - cy).
  const Eigen::Vector3d X = P + t0 * (Q - P);
  EXPECT_NEAR(cam.Project(X).y(), cam.height - 1.0, 1e-9);
  EXPECT_NEAR(X.z(), cam.fy * 1.65 / (cam.height - 1.0 - cam.cy), 1e-9);

  // A segment wholly in view is kept whole; one from behind the camera starts at min_depth
  // (then the image border); one wholly outside has no part in view.
  ASSERT_TRUE(cam.SegmentInView({0.0, 0.0, 5.0}, {1.0, -0.5, 9.0}, 0.05, &t0, &t1));
  EXPECT_DOUBLE_EQ(t0, 0.0);
  EXPECT_DOUBLE_EQ(t1, 1.0);
  ASSERT_TRUE(cam.SegmentInView({0.0, 0.0, -4.0}, {0.0, 0.0, 6.0}, 0.05, &t0, &t1));
  EXPECT_NEAR(-4.0 + 10.0 * t0, 0.05, 1e-12);
  t0 = t1 = 7.0;
  EXPECT_FALSE(cam.SegmentInView({-30.0, 0.0, 5.0}, {-20.0, 0.0, 6.0}, 0.05, &t0, &t1));
  EXPECT_FALSE(cam.SegmentInView({0.0, 0.0, -5.0}, {1.0, 0.0, -1.0}, 0.05, &t0, &t1));
  EXPECT_EQ(t0, 7.0);  // untouched
}

TEST(ClipLineToView, KeepsThePartThePredictedPoseShowsOnTheSameLine) {
  const StereoCamera cam = CarCamera();
  const SE3 T_cur_prev(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, -2.4));
  LineMatch3D2D m;
  m.P_prev = {-1.65, 1.65, 6.4};  // at the bottom of the previous image
  m.Q_prev = {-1.65, 1.65, 60.0};
  const LineMatch3D2D before = m;
  ASSERT_TRUE(ClipLineToView(cam, T_cur_prev, 0.05, &m));
  for (const Eigen::Vector3d& X : {m.P_prev, m.Q_prev}) {
    EXPECT_TRUE(cam.InImage(cam.Project(T_cur_prev * X), -1e-6));
    // Still on the reference line.
    EXPECT_LT((X - before.P_prev).cross(before.Q_prev - before.P_prev).norm(), 1e-9);
  }
  EXPECT_GT(m.P_prev.z(), before.P_prev.z() + 1.0);  // the near end moved into view
  EXPECT_EQ(m.Q_prev, before.Q_prev);

  // Nothing in view: the match is left as it was.
  LineMatch3D2D behind = before;
  EXPECT_FALSE(ClipLineToView(cam, SE3(Eigen::Matrix3d::Identity(), {0.0, 0.0, -80.0}), 0.05,
                              &behind));
  EXPECT_EQ(behind.P_prev, before.P_prev);
  EXPECT_EQ(behind.Q_prev, before.Q_prev);
}

}  // namespace
}  // namespace pl_slam
