// Depth noise in the motion estimate: a driving-like stereo camera moving forwards, previous-
// frame points and segments triangulated from noisy pixels and disparities. Propagating the
// disparity noise into the residuals (PointMatch3D2D::depth_noise) must lower the error of the
// motion and keep its covariance honest; without motion it must change nothing.
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "pl_slam/tracking/motion_estimator.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// KITTI's camera: 1241 x 376, f = 718 px, b = 0.54 m.
StereoCamera DrivingCamera() { return testing_util::CenteredCamera(718.0, 0.54, 1241, 376); }

Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d l =
      Eigen::Vector3d(a.x(), a.y(), 1.0).cross(Eigen::Vector3d(b.x(), b.y(), 1.0));
  return l / l.head<2>().norm();
}

// Matches of one frame pair: each previous-frame 3D position is triangulated from its left
// pixel and disparity, all three with noise_px of Gaussian noise (the disparity's is the
// difference of two: sqrt(2) noise_px); current observations carry noise_px too. Segments are
// twice as precise as points in all of these (weight 4).
struct Pair {
  PointMatches3D2D points;
  LineMatches3D2D lines;
};

Pair MakePair(const StereoCamera& cam, const SE3& T, double noise_px, double depth_noise,
              std::mt19937* rng) {
  std::uniform_real_distribution<double> uu(0.0, cam.width - 1.0), uv(0.0, cam.height - 1.0);
  std::uniform_real_distribution<double> depth(4.0, 40.0), unit(-1.0, 1.0);
  std::normal_distribution<double> n(0.0, noise_px), nl(0.0, 0.5 * noise_px);
  auto visible = [&](const Eigen::Vector3d& X) {
    return X.z() > 1.0 && cam.InImage(cam.Project(X), 2.0);
  };
  // A true point visible in both frames and its noisy stereo triangulation.
  auto stereo = [&](Eigen::Vector3d* truth, std::normal_distribution<double>& noise) {
    for (;;) {
      const double u = uu(*rng), v = uv(*rng), d = cam.DisparityFromDepth(depth(*rng));
      *truth = cam.BackProject(u, v, d);
      if (!visible(T * *truth)) continue;
      return cam.BackProject(u + noise(*rng), v + noise(*rng), d + std::sqrt(2.0) * noise(*rng));
    }
  };
  Pair p;
  for (int i = 0; i < 200; ++i) {
    PointMatch3D2D m;
    Eigen::Vector3d truth;
    m.P_prev = stereo(&truth, n);
    m.uv_cur = cam.Project(T * truth) + Eigen::Vector2d(n(*rng), n(*rng));
    m.depth_noise = depth_noise;
    p.points.push_back(m);
  }
  while (p.lines.size() < 40) {
    // Steep segments: an endpoint's disparity is as precise as the segment's own position.
    Eigen::Vector3d P, Q;
    LineMatch3D2D m;
    m.P_prev = stereo(&P, nl);
    Q = P + Eigen::Vector3d(0.1 * unit(*rng), 1.0, 0.1 * unit(*rng));
    if (!visible(Q) || !visible(T * Q)) continue;
    const Eigen::Vector2d q_prev = cam.Project(Q);
    m.Q_prev = cam.BackProject(q_prev.x() + nl(*rng), q_prev.y() + nl(*rng),
                               cam.DisparityFromDepth(Q.z()) + std::sqrt(2.0) * nl(*rng));
    const Eigen::Vector2d a = cam.Project(T * P), b = cam.Project(T * Q);
    m.l_cur = LineThrough(a + Eigen::Vector2d(nl(*rng), nl(*rng)),
                          b + Eigen::Vector2d(nl(*rng), nl(*rng)));
    m.weight = 4.0;
    m.depth_noise = depth_noise;
    p.lines.push_back(m);
  }
  return p;
}

struct Trials {
  double rms_t = 0.0;      // RMS translation error, m
  double chi2_mean = 0.0;  // mean whitened error; 6 when the covariance is honest
};

Trials RunTrials(const SE3& T, double depth_noise, int trials, unsigned seed) {
  const StereoCamera cam = DrivingCamera();
  std::mt19937 rng(seed);
  Trials out;
  for (int i = 0; i < trials; ++i) {
    const Pair p = MakePair(cam, T, 0.5, depth_noise, &rng);
    const MotionEstimate e = EstimateMotion(cam, p.points, p.lines, T, MotionEstimatorOptions());
    EXPECT_TRUE(e.success) << e.failure;
    if (!e.success) continue;
    const Vector6d d = (T * e.T_cur_prev.inverse()).Log();
    out.chi2_mean += d.dot(e.covariance.ldlt().solve(d)) / trials;
    out.rms_t += (e.T_cur_prev * T.inverse()).translation().squaredNorm() / trials;
  }
  out.rms_t = std::sqrt(out.rms_t);
  return out;
}

TEST(DepthNoise, ForwardMotionIsEstimatedMoreAccuratelyAndItsCovarianceStaysHonest) {
  // 1.2 m forwards and 2 degrees of yaw: a car at 12 m/s and 10 Hz.
  const SE3 T(ExpSO3(Eigen::Vector3d(0.0, 2.0 * kDeg, 0.0)), Eigen::Vector3d(0.02, 0.0, -1.2));
  const Trials exact = RunTrials(T, 0.0, 150, 5);
  const Trials modelled = RunTrials(T, 1.0, 150, 5);  // the same draws
  std::printf(
      "forward 1.2 m: depths exact: RMS %.2f mm, chi2 mean %.2f; depth noise modelled: RMS "
      "%.2f mm, chi2 mean %.2f\n",
      1e3 * exact.rms_t, exact.chi2_mean, 1e3 * modelled.rms_t, modelled.chi2_mean);
  EXPECT_LT(modelled.rms_t, 0.95 * exact.rms_t);  // 10% lower when written
  EXPECT_GT(exact.chi2_mean, 7.5);  // taken as exact, the depths make it overconfident
  EXPECT_NEAR(modelled.chi2_mean, 6.0, 1.0);
}

TEST(DepthNoise, WithoutMotionItChangesNothing) {
  const StereoCamera cam = DrivingCamera();
  std::mt19937 rng(9);
  const Pair a = MakePair(cam, SE3(), 0.5, 0.0, &rng);
  Pair b = a;
  for (auto& m : b.points) m.depth_noise = 1.0;
  for (auto& m : b.lines) m.depth_noise = 1.0;
  const MotionEstimate ea = EstimateMotion(cam, a.points, a.lines, SE3(), MotionEstimatorOptions());
  const MotionEstimate eb = EstimateMotion(cam, b.points, b.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(ea.success && eb.success);
  EXPECT_LT((ea.T_cur_prev * eb.T_cur_prev.inverse()).translation().norm(), 1e-5);
  EXPECT_EQ(ea.point_inliers, eb.point_inliers);
}

TEST(DepthNoise, NegativeOrNonFiniteNoiseIgnoresTheMatch) {
  const StereoCamera cam = DrivingCamera();
  std::mt19937 rng(11);
  Pair p = MakePair(cam, SE3(), 0.5, 1.0, &rng);
  p.points[0].depth_noise = -1.0;
  p.points[1].depth_noise = std::nan("");
  p.lines[0].depth_noise = INFINITY;
  const MotionEstimate e = EstimateMotion(cam, p.points, p.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_EQ(e.point_inlier[0] + e.point_inlier[1] + e.line_inlier[0], 0);
  EXPECT_GT(e.point_inliers, 150);
}

}  // namespace
}  // namespace pl_slam
