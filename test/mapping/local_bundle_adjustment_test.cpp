// Local bundle adjustment of a new keyframe that sees few landmarks, all on one wall (a bare
// corner, a whiteboard close up): one landmark put at a wrong depth by the keyframe before, or
// one segment associated with a landmark elsewhere in the view, observed far from its
// projection, must neither drag the keyframe along its weak direction nor stay in the map.
#include <gtest/gtest.h>

#include <cmath>
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

/// Stereo observation of a world segment by a keyframe, exact.
LineFeature ObserveLine(const StereoCamera& cam, const SE3& T_w_c, const Eigen::Vector3d& P_w,
                        const Eigen::Vector3d& Q_w) {
  LineFeature f;
  f.P_c = T_w_c.inverse() * P_w;
  f.Q_c = T_w_c.inverse() * Q_w;
  f.s = cam.Project(f.P_c);
  f.e = cam.Project(f.Q_c);
  const Eigen::Vector3d l =
      Eigen::Vector3d(f.s.x(), f.s.y(), 1.0).cross(Eigen::Vector3d(f.e.x(), f.e.y(), 1.0));
  f.l = l / l.head<2>().norm();
  f.angle = std::atan2(f.e.y() - f.s.y(), f.e.x() - f.s.x());
  f.length = (f.e - f.s).norm();
  f.has_depth = true;
  return f;
}

using Poses = std::vector<SE3, Eigen::aligned_allocator<SE3>>;

/// Keyframe k of a walk straight ahead, 5 cm a step; its pose is appended to `truth`.
std::shared_ptr<Keyframe> WalkKeyframe(int k, Poses* truth) {
  const SE3 T(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 0.05 * k));
  truth->push_back(T);
  auto kf = std::make_shared<Keyframe>();
  kf->id = k;
  kf->frame_index = k;
  kf->parent = k == 0 ? kNoId : k - 1;
  kf->T_w_c = T;
  return kf;
}

/// Keyframe k's point i observes the landmark `*id` at p_w (made there when it is new).
void ObservePoint(Map* map, const Eigen::Vector3d& p_w, KeyframeId k, int i, LandmarkId* id) {
  if (*id == kNoId)
    *id = map->AddPointLocked(p_w, k, i);
  else
    map->AddPointObservationLocked(*id, k, i);
}

struct Scene {
  mapping::Context ctx;
  Map map;
  Poses truth;  // per keyframe
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
    auto kf = WalkKeyframe(k, &s->truth);
    const SE3 T = kf->T_w_c;
    const size_t seen = k < 4 ? wall.size() : 8;
    for (size_t i = 0; i < seen; ++i)
      kf->features.points.push_back(Observe(s->ctx.camera, T, wall[i]));
    const Eigen::Vector3d wrong_w(0.1, 0.05, 0.15 + 0.85);  // 0.85 m ahead of keyframe 3
    if (k >= 3)
      kf->features.points.push_back(Observe(s->ctx.camera, T, wrong_w, k == 4 ? 15.0 : 0.0));
    const int n = static_cast<int>(kf->features.points.size());
    kf->features.point_descriptors = cv::Mat::zeros(n, 32, CV_8U);
    s->map.AddKeyframeLocked(kf);
    for (size_t i = 0; i < seen; ++i)
      ObservePoint(&s->map, wall[i], k, static_cast<int>(i), &ids[i]);
    if (k == 3) s->wrong = s->map.AddPointLocked(wrong_w, k, n - 1);
    if (k == 4) s->map.AddPointObservationLocked(s->wrong, k, n - 1);
  }
}

/// Local bundle adjustment of the new keyframe 4 (10 iterations): it must end within 2 mm and
/// 0.05 deg of `truth`.
void SolveTheNewKeyframe(mapping::Context* ctx, const SE3& truth) {
  ctx->options.ba.max_iterations = 10;
  const BaSummary summary = mapping::LocalBundleAdjustment(*ctx, 4);
  ASSERT_TRUE(summary.success) << summary.message;
  auto lock = ctx->map->Lock();
  const SE3 error = truth.inverse() * ctx->map->KeyframeLocked(4)->T_w_c;
  EXPECT_LT(error.translation().norm(), 0.002);
  EXPECT_LT(error.RotationAngle() * 180.0 / M_PI, 0.05);
}

TEST(LocalBundleAdjustment, AFarObservationOfTheNewKeyframeIsLeftOutAndRemoved) {
  Scene s;
  Build(&s);
  SolveTheNewKeyframe(&s.ctx, s.truth[4]);
  auto lock = s.map.Lock();
  const auto wrong = s.map.PointLocked(s.wrong);
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->observations.count(4), 0u);
  EXPECT_EQ(wrong->observations.count(3), 1u);  // where it was made, it stays
}

/// Keyframes 0-4 walking towards a wall 1.5 m ahead, 5 cm apart, the new keyframe 4 seeing
/// only a strip of it 10 cm wide (a whiteboard's edge): 8 points and four vertical segments
/// there, all seen by keyframes 0-3 too, which also see the rest of the wall and a door
/// frame's edge 0.9 m to the left. Keyframe 4's segment `wrong_obs` is the strip's fifth edge,
/// associated with the door frame's landmark: 300+ px from that landmark's projection.
struct LineScene {
  mapping::Context ctx;
  Map map;
  Poses truth;
  std::vector<LandmarkId> strip_lines;
  LandmarkId door = kNoId;
};

void BuildLines(LineScene* s) {
  s->ctx.camera = testing_util::EurocSizedCamera();
  s->ctx.map = &s->map;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-1.0, 1.0), uy(-0.6, 0.6), strip(-0.05, 0.05);
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points;
  for (int i = 0; i < 8; ++i) points.emplace_back(strip(rng), uy(rng), 1.5);  // the strip first
  for (int i = 0; i < 40; ++i) points.emplace_back(ux(rng), uy(rng), 1.5);
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> lines;
  for (int i = 0; i < 4; ++i) {
    const double x = -0.04 + 0.025 * i;
    lines.emplace_back(Eigen::Vector3d(x, -0.4, 1.5), Eigen::Vector3d(x, 0.4, 1.5));
  }
  lines.emplace_back(Eigen::Vector3d(-0.9, -0.5, 1.5), Eigen::Vector3d(-0.9, 0.5, 1.5));  // door
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> fifth(Eigen::Vector3d(0.05, -0.4, 1.5),
                                                          Eigen::Vector3d(0.05, 0.4, 1.5));
  std::vector<LandmarkId> point_ids(points.size(), kNoId), line_ids(lines.size(), kNoId);
  auto lock = s->map.Lock();
  for (int k = 0; k < 5; ++k) {
    auto kf = WalkKeyframe(k, &s->truth);
    const SE3 T = kf->T_w_c;
    const size_t seen_points = k < 4 ? points.size() : 8;
    for (size_t i = 0; i < seen_points; ++i)
      kf->features.points.push_back(Observe(s->ctx.camera, T, points[i]));
    kf->features.point_descriptors = cv::Mat::zeros(static_cast<int>(seen_points), 32, CV_8U);
    for (size_t i = 0; i < 4; ++i)
      kf->features.lines.push_back(ObserveLine(s->ctx.camera, T, lines[i].first, lines[i].second));
    kf->features.lines.push_back(
        k < 4 ? ObserveLine(s->ctx.camera, T, lines[4].first, lines[4].second)
              : ObserveLine(s->ctx.camera, T, fifth.first, fifth.second));
    kf->features.line_descriptors = cv::Mat::zeros(5, 32, CV_8U);
    s->map.AddKeyframeLocked(kf);
    for (size_t i = 0; i < seen_points; ++i)
      ObservePoint(&s->map, points[i], k, static_cast<int>(i), &point_ids[i]);
    for (size_t i = 0; i < lines.size(); ++i) {
      if (line_ids[i] == kNoId)
        line_ids[i] = s->map.AddLineLocked(lines[i].first, lines[i].second, k, static_cast<int>(i));
      else
        s->map.AddLineObservationLocked(line_ids[i], k, static_cast<int>(i));
    }
  }
  s->strip_lines.assign(line_ids.begin(), line_ids.begin() + 4);
  s->door = line_ids[4];
}

TEST(LocalBundleAdjustment, ASegmentOfTheNewKeyframeFarFromItsLandmarkIsLeftOutAndRemoved) {
  LineScene s;
  BuildLines(&s);
  {
    // The association is 300+ px off where keyframe 4 sees the door frame's landmark.
    auto lock = s.map.Lock();
    const auto kf = s.map.KeyframeLocked(4);
    const Eigen::Vector2d door =
        s.ctx.camera.Project(kf->T_w_c.inverse() * s.map.LineLocked(s.door)->P_w);
    ASSERT_GT(std::abs(door.x() - kf->features.lines[4].s.x()), 300.0);
  }
  SolveTheNewKeyframe(&s.ctx, s.truth[4]);
  auto lock = s.map.Lock();
  const auto door = s.map.LineLocked(s.door);
  ASSERT_TRUE(door);
  EXPECT_EQ(door->observations.count(4), 0u);
  EXPECT_EQ(door->observations.count(3), 1u);
  for (LandmarkId id : s.strip_lines) {  // the strip's own segments stay
    const auto line = s.map.LineLocked(id);
    ASSERT_TRUE(line);
    EXPECT_EQ(line->observations.count(4), 1u);
  }
}

}  // namespace
}  // namespace pl_slam
