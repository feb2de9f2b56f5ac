// Keyframe insertion's matches against the previous keyframe: when the pose estimate from them
// is not used, only the matches that fit the tracked pose become observations.
#include <gtest/gtest.h>

#include <random>

#include "../../src/mapping/mapping_steps.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

using Points = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

const SE3 kT_w_0 = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
const SE3 kT_w_1 = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 0.05));

struct Scene {
  mapping::Context ctx;
  Map map;
  Points wall;
  cv::Mat point_descriptors;
  std::vector<LandmarkId> wall_ids;
};

/// Keyframe 0 at the origin: `n` wall points 2 m ahead, all landmarks.
void Build(int n, Scene* s) {
  s->ctx.camera = testing_util::EurocSizedCamera();
  s->ctx.map = &s->map;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-1.0, 1.0), uy(-0.6, 0.4);
  for (int i = 0; i < n; ++i) s->wall.emplace_back(ux(rng), uy(rng), 2.0);
  cv::theRNG().state = 11;
  s->point_descriptors = cv::Mat(n, 32, CV_8U);
  cv::randu(s->point_descriptors, 0, 256);

  auto kf = std::make_shared<Keyframe>();
  kf->id = 0;
  kf->frame_index = 0;
  kf->T_w_c = kT_w_0;
  const StereoCamera& cam = s->ctx.camera;
  for (const Eigen::Vector3d& p : s->wall) {
    PointFeature f;
    f.p_c = p;
    f.uv = cam.Project(p);
    f.has_depth = true;
    f.disparity = cam.DisparityFromDepth(p.z());
    kf->features.points.push_back(f);
  }
  kf->features.point_descriptors = s->point_descriptors.clone();
  kf->features.line_descriptors = cv::Mat(0, 32, CV_8U);
  auto lock = s->map.Lock();
  s->map.AddKeyframeLocked(kf);
  for (int i = 0; i < n; ++i) s->wall_ids.push_back(s->map.AddPointLocked(s->wall[i], 0, i));
}

/// Keyframe 1, 5 cm ahead, tracked exactly, sees the wall points `shift_px` to the right of where
/// they are (a repeated texture's copy; 0: the points themselves), without stereo depth.
KeyframeInput NextKeyframe(const Scene& s, double shift_px) {
  KeyframeInput in;
  in.id = 1;
  in.frame_index = 1;
  in.T_w_c = kT_w_1;
  const SE3 T_c_w = kT_w_1.inverse();
  for (const Eigen::Vector3d& p : s.wall) {
    PointFeature f;
    f.uv = s.ctx.camera.Project(T_c_w * p) + Eigen::Vector2d(shift_px, 0.0);
    in.features.points.push_back(f);
  }
  in.features.point_descriptors = s.point_descriptors.clone();
  in.features.line_descriptors = cv::Mat(0, 32, CV_8U);
  return in;
}

std::vector<LandmarkId> PointLandmarksOf(Map* map, KeyframeId id) {
  auto lock = map->Lock();
  return map->KeyframeLocked(id)->point_landmarks;
}

// Twelve matches (fewer than mapping.refine_min_inliers) all agree on a pose 20 px of image
// motion away from the tracked one: the estimate succeeds with every match an inlier, but it is
// not used, and at the tracked pose the matches are 20 px off: none becomes an observation. The
// same twelve matches where the points are seen keep all twelve.
TEST(KeyframeInsertion, MatchesOfAnEstimateNotUsedMustFitTheTrackedPose) {
  for (const double shift_px : {20.0, 0.0}) {
    Scene s;
    Build(12, &s);
    ASSERT_LT(12, s.ctx.options.refine_min_inliers);
    KeyframeInput in = NextKeyframe(s, shift_px);
    mapping::InsertKeyframe(s.ctx, &in);
    const std::vector<LandmarkId> seen = PointLandmarksOf(&s.map, 1);
    int observed = 0;
    for (size_t i = 0; i < s.wall_ids.size(); ++i) observed += seen[i] == s.wall_ids[i];
    EXPECT_EQ(observed, shift_px == 0.0 ? 12 : 0) << "shift " << shift_px << " px";
    SE3 T;
    ASSERT_TRUE(s.map.KeyframePose(1, &T));
    EXPECT_LT((T.translation() - kT_w_1.translation()).norm(), 1e-9) << "the tracked pose stays";
  }
}

}  // namespace
}  // namespace pl_slam
