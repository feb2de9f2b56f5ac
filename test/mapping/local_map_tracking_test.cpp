// Tracking a frame against the local map: the gate decides what is accepted (fewest
// inliers, largest correction of the prior) and the estimate's covariance comes back, so that a
// caller can relax the count for a tight estimate.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>

#include "pl_slam/mapping/local_map_matching.h"
#include "pl_slam/tracking/motion_estimator.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

// `n` landmarks spread over the view of a camera at the origin (2-4 m deep), and the frame a
// camera at T_w_c sees: their exact projections, stereo depth, the landmarks' descriptors.
struct Scene {
  LocalMap local;
  StereoFeatures frame;
};

Scene MakeScene(const StereoCamera& cam, int n, const SE3& T_w_c) {
  Scene s;
  cv::RNG rng(11);
  s.local.point_descriptors.create(n, 32, CV_8UC1);
  rng.fill(s.local.point_descriptors, cv::RNG::UNIFORM, 0, 256);
  s.frame.point_descriptors = s.local.point_descriptors.clone();
  for (int i = 0; i < n; ++i) {
    const double u = 80.0 + (cam.width - 160.0) * ((i * 7) % n) / (n - 1.0);
    const double v = 80.0 + (cam.height - 160.0) * ((i * 3) % n) / (n - 1.0);
    const double z = 2.0 + 2.0 * i / (n - 1.0);
    PointFeature lm;
    lm.p_c = Eigen::Vector3d((u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z);
    lm.has_depth = true;
    s.local.points.push_back(lm);
    s.local.point_ids.push_back(i);
    PointFeature f;
    f.p_c = T_w_c.inverse() * lm.p_c;
    f.uv = cam.Project(f.p_c);
    f.has_depth = true;
    f.disparity = cam.fx * cam.baseline / f.p_c.z();
    s.frame.points.push_back(f);
  }
  return s;
}

TEST(TrackLocalMap, TheGateDecidesTheCountAndTheCorrection) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  const MappingOptions options;
  const MappingFrontEnd front_end;
  const SE3 truth(ExpSO3(Eigen::Vector3d(0.0, 0.3 * kPi / 180.0, 0.0)),
                  Eigen::Vector3d(0.015, 0.0, 0.0));
  const int n = 12;  // below the default gate (track_min_inliers)
  ASSERT_LT(n, options.track_min_inliers);
  const Scene s = MakeScene(cam, n, truth);
  const SE3 prior;  // the prediction: 1.5 cm and 0.3 degrees off

  const LocalMapTracking strict = TrackLocalMap(cam, s.frame, s.local, prior, options, front_end);
  EXPECT_FALSE(strict.success);
  EXPECT_EQ(strict.point_matches, n);

  LocalMapGate relaxed;
  relaxed.min_inliers = 8;
  relaxed.max_correction = 0.05;
  relaxed.max_correction_deg = 3.0;
  const LocalMapTracking held =
      TrackLocalMap(cam, s.frame, s.local, prior, options, front_end, &relaxed);
  ASSERT_TRUE(held.success) << held.failure;
  EXPECT_EQ(held.point_inliers, n);
  EXPECT_LT((held.T_w_c.translation() - truth.translation()).norm(), 1e-4);
  EXPECT_LT((held.T_w_c.inverse() * truth).RotationAngle(), 1e-4);
  EXPECT_EQ(held.point_associations.size(), static_cast<size_t>(n));
  // Exact data: the covariance is the estimator's floor, tight but not zero.
  EXPECT_GT(held.covariance.trace(), 0.0);
  EXPECT_TRUE(SigmaWithin(held.covariance, 0.05, 3.0 * kPi / 180.0));
  EXPECT_FALSE(SigmaWithin(held.covariance, 1e-9, 1e-9));

  // The same frame with a correction larger than the gate allows is refused.
  LocalMapGate narrow = relaxed;
  narrow.max_correction = 0.01;
  const LocalMapTracking refused =
      TrackLocalMap(cam, s.frame, s.local, prior, options, front_end, &narrow);
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.failure.find("correction"), std::string::npos) << refused.failure;
}

}  // namespace
}  // namespace pl_slam
