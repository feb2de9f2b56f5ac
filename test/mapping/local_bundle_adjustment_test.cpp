// Local bundle adjustment of a new keyframe that sees few landmarks, all on one wall (a bare
// corner): one landmark put at a wrong depth by the keyframe before, observed far from its
// projection, must neither drag the keyframe along its weak direction nor stay in the map.
#include <gtest/gtest.h>

#include <random>

#include "../../src/mapping/mapping_steps.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

/// Stereo observation of a world point by a keyframe, exact (or `shift_px` off in the left
/// image, without stereo).
PointFeature Observe(const StereoCamera& cam, const SE3& T_w_c, const Eigen::Vector3d& p_w,
                     double shift_px = 0.0) {
  PointFeature f;
  f.p_c = T_w_c.inverse() * p_w;
  f.uv = cam.Project(f.p_c) + Eigen::Vector2d(shift_px, 0.6 * shift_px);
  f.has_depth = shift_px == 0.0;
  f.disparity = f.has_depth ? cam.DisparityFromDepth(f.p_c.z()) : 0.0;
  return f;
}

struct Scene {
  mapping::Context ctx;
  Map map;
  std::vector<SE3, Eigen::aligned_allocator<SE3>> truth;  // per keyframe
  LandmarkId wrong = kNoId;
};

/// Keyframes 0-4 walking towards a wall 2 m ahead, 5 cm apart. Keyframes 0-3 see 60 wall
/// points; the new keyframe 4 sees 8 of them, and a point keyframe 3 put at 0.85 m (a noise
/// corner's wrong stereo match) 17 px from where keyframe 4 observes it.
void Build(Scene* s) {
  s->ctx.camera = testing_util::EurocSizedCamera();
  s->ctx.map = &s->map;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-1.2, 1.2), uy(-0.8, 0.8);
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> wall;
  for (int i = 0; i < 60; ++i) wall.emplace_back(ux(rng), uy(rng), 2.0);
  std::vector<LandmarkId> ids(wall.size(), kNoId);
  auto lock = s->map.Lock();
  for (int k = 0; k < 5; ++k) {
    const SE3 T(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 0.05 * k));
    s->truth.push_back(T);
    auto kf = std::make_shared<Keyframe>();
    kf->id = k;
    kf->frame_index = k;
    kf->parent = k == 0 ? kNoId : k - 1;
    kf->T_w_c = T;
    const size_t seen = k < 4 ? wall.size() : 8;
    for (size_t i = 0; i < seen; ++i)
      kf->features.points.push_back(Observe(s->ctx.camera, T, wall[i]));
    const Eigen::Vector3d wrong_w(0.1, 0.05, 0.15 + 0.85);  // 0.85 m ahead of keyframe 3
    if (k >= 3)
      kf->features.points.push_back(Observe(s->ctx.camera, T, wrong_w, k == 4 ? 15.0 : 0.0));
    const int n = static_cast<int>(kf->features.points.size());
    kf->features.point_descriptors = cv::Mat::zeros(n, 32, CV_8U);
    s->map.AddKeyframeLocked(kf);
    for (size_t i = 0; i < seen; ++i) {
      if (ids[i] == kNoId)
        ids[i] = s->map.AddPointLocked(wall[i], k, static_cast<int>(i));
      else
        s->map.AddPointObservationLocked(ids[i], k, static_cast<int>(i));
    }
    if (k == 3) s->wrong = s->map.AddPointLocked(wrong_w, k, n - 1);
    if (k == 4) s->map.AddPointObservationLocked(s->wrong, k, n - 1);
  }
}

TEST(LocalBundleAdjustment, AFarObservationOfTheNewKeyframeIsLeftOutAndRemoved) {
  Scene s;
  Build(&s);
  s.ctx.options.ba.max_iterations = 10;
  const BaSummary summary = mapping::LocalBundleAdjustment(s.ctx, 4);
  ASSERT_TRUE(summary.success) << summary.message;
  auto lock = s.map.Lock();
  const SE3 error = s.truth[4].inverse() * s.map.KeyframeLocked(4)->T_w_c;
  EXPECT_LT(error.translation().norm(), 0.002);
  EXPECT_LT(error.RotationAngle() * 180.0 / M_PI, 0.05);
  const auto wrong = s.map.PointLocked(s.wrong);
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->observations.count(4), 0u);
  EXPECT_EQ(wrong->observations.count(3), 1u);  // where it was made, it stays
}

}  // namespace
}  // namespace pl_slam
