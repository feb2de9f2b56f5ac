// The map: ownership (culled objects freed), observations both ways, covisibility and the
// essential graph, culled keyframes still resolving poses, snapshots and local maps.
#include <gtest/gtest.h>

#include "pl_slam/map/map.h"

namespace pl_slam {
namespace {

/// A keyframe with `n` point features (all with depth) and `m` line features.
std::shared_ptr<Keyframe> MakeKeyframe(KeyframeId id, int n, int m, const SE3& T_w_c) {
  auto kf = std::make_shared<Keyframe>();
  kf->id = id;
  kf->frame_index = static_cast<int>(10 * id);
  kf->T_w_c = T_w_c;
  kf->features.points.resize(n);
  for (int i = 0; i < n; ++i) {
    kf->features.points[i].has_depth = true;
    kf->features.points[i].p_c = Eigen::Vector3d(0.01 * i, 0.0, 2.0);
  }
  kf->features.point_descriptors = cv::Mat(n, 32, CV_8U, cv::Scalar(static_cast<int>(id)));
  kf->features.lines.resize(m);
  kf->features.line_descriptors = cv::Mat(m, 32, CV_8U, cv::Scalar(7));
  return kf;
}

SE3 Translation(double x) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0, 0)); }

TEST(MapTest, ObservationsAreKeptBothWaysAndOrphansAreFreed) {
  Map map;
  std::weak_ptr<PointLandmark> weak;
  {
    auto lock = map.Lock();
    map.AddKeyframeLocked(MakeKeyframe(0, 5, 2, SE3()));
    map.AddKeyframeLocked(MakeKeyframe(1, 5, 2, Translation(0.1)));
    const LandmarkId a = map.AddPointLocked(Eigen::Vector3d(0, 0, 2), 0, 3);
    ASSERT_NE(a, kNoId);
    EXPECT_EQ(map.AddPointLocked(Eigen::Vector3d(0, 0, 2), 0, 3), kNoId);  // feature taken
    EXPECT_TRUE(map.AddPointObservationLocked(a, 1, 4));
    EXPECT_FALSE(map.AddPointObservationLocked(a, 1, 2));  // one observation per keyframe
    EXPECT_FALSE(map.AddPointObservationLocked(a, 7, 0));  // unknown keyframe
    EXPECT_EQ(map.KeyframeLocked(0)->point_landmarks[3], a);
    EXPECT_EQ(map.KeyframeLocked(1)->point_landmarks[4], a);
    weak = map.PointLocked(a);
    map.RemovePointObservationLocked(a, 0);
    EXPECT_EQ(map.KeyframeLocked(0)->point_landmarks[3], kNoId);
    EXPECT_FALSE(weak.expired());
    map.RemovePointObservationLocked(a, 1);  // last observation: the landmark goes
    EXPECT_EQ(map.PointLocked(a), nullptr);
  }
  EXPECT_TRUE(weak.expired()) << "a landmark without observations must be freed";
  EXPECT_EQ(map.counts().points, 0u);
}

TEST(MapTest, CovisibilityAndEssentialGraphFollowSharedLandmarks) {
  MapOptions options;
  options.covisibility_min_shared = 3;
  options.essential_min_shared = 5;
  Map map(options);
  auto lock = map.Lock();
  for (int k = 0; k < 3; ++k) map.AddKeyframeLocked(MakeKeyframe(k, 10, 0, Translation(k)));
  // 0-1 share 8 landmarks, 1-2 share 3, 0-2 share 1.
  for (int i = 0; i < 8; ++i) {
    const LandmarkId lm = map.AddPointLocked(Eigen::Vector3d(i, 0, 3), 0, i);
    map.AddPointObservationLocked(lm, 1, i);
    if (i < 1) map.AddPointObservationLocked(lm, 2, i);
  }
  for (int i = 8; i < 10; ++i) {
    const LandmarkId lm = map.AddPointLocked(Eigen::Vector3d(i, 0, 3), 1, i);
    map.AddPointObservationLocked(lm, 2, i);
  }
  const LandmarkId lone = map.AddPointLocked(Eigen::Vector3d(1, 1, 3), 2, 1);
  EXPECT_FALSE(map.AddPointObservationLocked(lone, 1, 0));  // feature 0 of keyframe 1 is taken
  const auto cov1 = map.CovisibleLocked(1, 1);
  ASSERT_EQ(cov1.size(), 2u);
  EXPECT_EQ(cov1[0], std::make_pair(KeyframeId(0), 8));
  EXPECT_EQ(cov1[1], std::make_pair(KeyframeId(2), 3));
  map.KeyframeLocked(1)->parent = 0;
  map.KeyframeLocked(2)->parent = 1;
  lock.unlock();
  const MapSnapshot snap = map.Snapshot();
  EXPECT_EQ(snap.keyframes.size(), 3u);
  EXPECT_EQ(snap.points.size(), 11u);
  const std::vector<std::pair<KeyframeId, KeyframeId>> covis{{0, 1}, {1, 2}};
  EXPECT_EQ(snap.covisibility_edges, covis);
  // Essential: 0-1 (8 > 5 shared, and the tree) and 1-2 (tree).
  EXPECT_EQ(snap.essential_edges, covis);
}

TEST(MapTest, ErasedKeyframeFreesItsLandmarksAndStillResolvesItsPose) {
  Map map;
  std::weak_ptr<Keyframe> weak_kf;
  {
    auto lock = map.Lock();
    map.AddKeyframeLocked(MakeKeyframe(0, 4, 1, SE3()));
    map.AddKeyframeLocked(MakeKeyframe(1, 4, 1, Translation(1.0)));
    map.AddKeyframeLocked(MakeKeyframe(2, 4, 1, Translation(2.0)));
    map.KeyframeLocked(1)->parent = 0;
    map.KeyframeLocked(2)->parent = 1;
    const LandmarkId shared = map.AddPointLocked(Eigen::Vector3d(0, 0, 3), 1, 0);
    map.AddPointObservationLocked(shared, 2, 0);
    map.AddPointLocked(Eigen::Vector3d(1, 0, 3), 1, 1);  // only keyframe 1 sees it
    map.AddLineLocked(Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(0, 1, 3), 1, 0);
    weak_kf = map.KeyframeLocked(1);
    map.EraseKeyframeLocked(1);
    EXPECT_EQ(map.KeyframeLocked(2)->parent, 0) << "children re-parented";
    EXPECT_NE(map.PointLocked(shared), nullptr);
  }
  EXPECT_TRUE(weak_kf.expired()) << "an erased keyframe must be freed";
  const MapCounts c = map.counts();
  EXPECT_EQ(c.keyframes, 2u);
  EXPECT_EQ(c.points, 1u);
  EXPECT_EQ(c.lines, 0u);
  EXPECT_EQ(c.culled_keyframes, 1u);
  // The culled keyframe's pose follows its parent.
  SE3 T;
  ASSERT_TRUE(map.KeyframePose(1, &T));
  EXPECT_NEAR(T.translation().x(), 1.0, 1e-12);
  {
    auto lock = map.Lock();
    map.KeyframeLocked(0)->T_w_c = Translation(5.0);
  }
  ASSERT_TRUE(map.KeyframePose(1, &T));
  EXPECT_NEAR(T.translation().x(), 6.0, 1e-12);
  EXPECT_FALSE(map.KeyframePose(42, &T));
}

TEST(MapTest, LocalMapCopiesTheNeighbourhoodOnce) {
  Map map;
  {
    auto lock = map.Lock();
    for (int k = 0; k < 3; ++k) map.AddKeyframeLocked(MakeKeyframe(k, 6, 0, Translation(k)));
    for (int i = 0; i < 6; ++i) {
      const LandmarkId lm = map.AddPointLocked(Eigen::Vector3d(i, 0, 4), 0, i);
      map.AddPointObservationLocked(lm, 1, i);
    }
    map.AddPointLocked(Eigen::Vector3d(0, 5, 4), 2, 0);  // keyframe 2 shares nothing
  }
  const LocalMap local = map.GetLocalMap(1, 10);
  EXPECT_EQ(local.reference, 1);
  ASSERT_EQ(local.point_ids.size(), 6u);  // each landmark once, keyframe 2's not included
  EXPECT_EQ(local.point_descriptors.rows, 6);
  EXPECT_EQ(local.points[2].p_c, Eigen::Vector3d(2, 0, 4));
  EXPECT_EQ(local.version, map.version());
  EXPECT_TRUE(map.GetLocalMap(99, 10).point_ids.empty());
  map.Clear();
  EXPECT_EQ(map.counts().keyframes, 0u);
  EXPECT_EQ(map.LastKeyframe(), kNoId);
}

}  // namespace
}  // namespace pl_slam
