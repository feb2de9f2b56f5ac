// Global bundle adjustment's three steps (copy, solve, merge) on a small map built from exact
// projections: perturbed keyframes and points go back to the truth, a keyframe and a point
// added while the solve ran follow their ancestor's correction, and an aborted solve leaves
// the map alone.
#include <gtest/gtest.h>

#include <random>

#include "../../src/mapping/mapping_steps.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

struct Fixture {
  mapping::Context ctx;
  Map map;
  std::vector<SE3, Eigen::aligned_allocator<SE3>> truth;  // per keyframe
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points;
  std::vector<LandmarkId> point_ids;
};

StereoCamera Camera() { return testing_util::EurocSizedCamera(); }

/// Observation of a world point by a keyframe, exact.
PointFeature Observe(const StereoCamera& cam, const SE3& T_w_c, const Eigen::Vector3d& p_w) {
  PointFeature f;
  f.p_c = T_w_c.inverse() * p_w;
  f.uv = cam.Project(f.p_c);
  f.has_depth = true;
  f.disparity = cam.DisparityFromDepth(f.p_c.z());
  return f;
}

SE3 Perturbation(std::mt19937* rng, double metres, double radians) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi[i] = metres * n(*rng);
  for (int i = 3; i < 6; ++i) xi[i] = radians * n(*rng);
  return SE3::Exp(xi);
}

/// Six keyframes along x, 300 points in front, every keyframe observing every visible point;
/// keyframes 1-5 and every point perturbed (keyframe 0 holds the gauge at the truth).
void Build(Fixture* f) {
  f->ctx.camera = Camera();
  f->ctx.map = &f->map;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-2.0, 3.0), uy(-1.2, 1.2), uz(3.0, 6.0);
  for (int i = 0; i < 300; ++i) f->points.emplace_back(ux(rng), uy(rng), uz(rng));
  auto lock = f->map.Lock();
  for (int k = 0; k < 6; ++k) {
    const SE3 T(Eigen::Quaterniond(Eigen::AngleAxisd(0.03 * k, Eigen::Vector3d::UnitY())),
                Eigen::Vector3d(0.2 * k, 0.02 * k, 0.0));
    f->truth.push_back(T);
    auto kf = std::make_shared<Keyframe>();
    kf->id = k;
    kf->frame_index = 10 * k;
    kf->parent = k == 0 ? kNoId : k - 1;
    kf->T_w_c = k == 0 ? T : T * Perturbation(&rng, 0.01, 0.005);
    std::vector<int> seen;
    for (size_t i = 0; i < f->points.size(); ++i) {
      const PointFeature obs = Observe(f->ctx.camera, T, f->points[i]);
      if (!f->ctx.camera.InImage(obs.uv, 2.0)) continue;
      kf->features.points.push_back(obs);
      seen.push_back(static_cast<int>(i));
    }
    kf->features.point_descriptors = cv::Mat::zeros(static_cast<int>(seen.size()), 32, CV_8U);
    f->map.AddKeyframeLocked(kf);
    if (k == 0) f->point_ids.assign(f->points.size(), kNoId);
    for (size_t j = 0; j < seen.size(); ++j) {
      const int i = seen[j];
      if (f->point_ids[i] == kNoId) {
        std::normal_distribution<double> n(0.0, 0.02);
        const Eigen::Vector3d noisy = f->points[i] + Eigen::Vector3d(n(rng), n(rng), n(rng));
        f->point_ids[i] = f->map.AddPointLocked(noisy, k, static_cast<int>(j));
      } else {
        f->map.AddPointObservationLocked(f->point_ids[i], k, static_cast<int>(j));
      }
    }
  }
}

/// Adds keyframe `id` (child of `parent`) observing one new point, as local mapping would
/// while a global BA is solving. Returns the point's id.
LandmarkId AddLaterKeyframe(Fixture* f, KeyframeId id, KeyframeId parent, const SE3& T_w_c) {
  auto lock = f->map.Lock();
  auto kf = std::make_shared<Keyframe>();
  kf->id = id;
  kf->parent = parent;
  kf->T_w_c = T_w_c;
  kf->features.points.push_back(Observe(f->ctx.camera, T_w_c, T_w_c * Eigen::Vector3d(0, 0, 4)));
  kf->features.point_descriptors = cv::Mat::zeros(1, 32, CV_8U);
  f->map.AddKeyframeLocked(kf);
  return f->map.AddPointLocked(T_w_c * Eigen::Vector3d(0, 0, 4), id, 0);
}

SE3 PoseOf(Fixture* f, KeyframeId id) {
  auto lock = f->map.Lock();
  return f->map.KeyframeLocked(id)->T_w_c;
}

TEST(GlobalBundleAdjustment, RecoversTheTruthAndMovesLaterKeyframesWithTheirAncestor) {
  Fixture f;
  Build(&f);
  mapping::GlobalBa job;
  ASSERT_TRUE(mapping::PrepareGlobalBundleAdjustment(f.ctx, &job));
  EXPECT_EQ(job.window.pose_ids.size(), 6u);
  EXPECT_GT(job.window.point_ids.size(), 250u);

  // Keyframes 6 (child of 5) and 7 (child of 6) arrive while the solve runs.
  const SE3 T6 = f.truth[5] * SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.2, 0, 0));
  const SE3 T7 = T6 * SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.2, 0, 0));
  const LandmarkId p6 = AddLaterKeyframe(&f, 6, 5, T6);
  AddLaterKeyframe(&f, 7, 6, T7);
  Eigen::Vector3d p6_before;
  {
    auto lock = f.map.Lock();
    p6_before = f.map.PointLocked(p6)->p_w;
  }

  mapping::SolveGlobalBundleAdjustment(f.ctx, 10, nullptr, &job);
  ASSERT_TRUE(job.summary.success) << job.summary.message;
  EXPECT_LT(job.summary.final_cost, 1e-3 * job.summary.initial_cost);
  const size_t i5 = std::find(job.window.pose_ids.begin(), job.window.pose_ids.end(), 5) -
                    job.window.pose_ids.begin();
  const SE3 C5 = job.window.problem.poses[i5].T_w_c * job.before[i5].inverse();
  ASSERT_TRUE(mapping::ApplyGlobalBundleAdjustment(f.ctx, job));

  for (int k = 0; k < 6; ++k) {
    const SE3 err = PoseOf(&f, k) * f.truth[k].inverse();
    EXPECT_LT(err.translation().norm(), 1e-4) << "keyframe " << k;
    EXPECT_LT(err.RotationAngle(), 1e-5) << "keyframe " << k;
  }
  {
    auto lock = f.map.Lock();
    for (size_t i = 0; i < f.points.size(); ++i) {
      if (f.point_ids[i] == kNoId) continue;
      const auto p = f.map.PointLocked(f.point_ids[i]);
      ASSERT_TRUE(p);
      EXPECT_LT((p->p_w - f.points[i]).norm(), 1e-3) << "point " << i;
    }
    // The later point moved with its keyframe, which moved with keyframe 5.
    EXPECT_LT((f.map.PointLocked(p6)->p_w - C5 * p6_before).norm(), 1e-9);
  }
  EXPECT_TRUE(PoseOf(&f, 6).matrix().isApprox((C5 * T6).matrix(), 1e-9));
  EXPECT_TRUE(PoseOf(&f, 7).matrix().isApprox((C5 * T7).matrix(), 1e-9));
  // The correction is not the identity, so the checks above could fail.
  EXPECT_GT(C5.translation().norm() + C5.RotationAngle(), 1e-3);
}

TEST(GlobalBundleAdjustment, AnAbortedSolveLeavesTheMapAlone) {
  Fixture f;
  Build(&f);
  mapping::GlobalBa job;
  ASSERT_TRUE(mapping::PrepareGlobalBundleAdjustment(f.ctx, &job));
  std::vector<SE3, Eigen::aligned_allocator<SE3>> before;
  for (int k = 0; k < 6; ++k) before.push_back(PoseOf(&f, k));
  std::atomic<bool> abort{true};
  mapping::SolveGlobalBundleAdjustment(f.ctx, 10, &abort, &job);
  EXPECT_FALSE(job.summary.success);
  EXPECT_EQ(job.summary.message, "aborted");
  EXPECT_FALSE(mapping::ApplyGlobalBundleAdjustment(f.ctx, job));
  for (int k = 0; k < 6; ++k)
    EXPECT_TRUE(PoseOf(&f, k).matrix().isApprox(before[k].matrix(), 0.0)) << "keyframe " << k;
}

TEST(GlobalBundleAdjustment, NeedsTwoKeyframes) {
  Fixture f;
  f.ctx.camera = Camera();
  f.ctx.map = &f.map;
  mapping::GlobalBa job;
  EXPECT_FALSE(mapping::PrepareGlobalBundleAdjustment(f.ctx, &job));
}

}  // namespace
}  // namespace pl_slam
