#include "pl_slam/system/frame_records.h"

#include <cmath>
#include <map>

#include <gtest/gtest.h>

namespace pl_slam {
namespace {

SE3 Translation(double x, double y, double z) {
  return SE3(Eigen::Matrix3d::Identity(), {x, y, z});
}

// Frames 0..9 at 10 Hz moving along x by 0.1 m; keyframe 1 is made at frame 0, keyframe 2 at
// frame 5 (a frame's reference is the last keyframe made at or before it).
struct Scene {
  FrameRecords records;
  std::map<KeyframeId, SE3> tracked_keyframes;  // keyframe poses when the frames were tracked
  Scene() {
    tracked_keyframes[1] = Translation(0.0, 0, 0);
    tracked_keyframes[2] = Translation(0.5, 0, 0);
    for (int i = 0; i < 10; ++i) {
      FrameRecord r;
      r.stamp_s = 0.1 * i;
      r.T_w_c = Translation(0.1 * i, 0, 0);
      r.reference = i < 5 ? 1 : 2;
      r.T_ref_c = tracked_keyframes[r.reference].inverse() * r.T_w_c;
      records.push_back(r);
    }
  }
};

KeyframePoseLookup Lookup(const std::map<KeyframeId, SE3>& poses) {
  return [poses](KeyframeId id, SE3* T) {
    const auto it = poses.find(id);
    if (it == poses.end()) return false;
    *T = it->second;
    return true;
  };
}

TEST(ResolveTrajectory, UnmovedKeyframesGiveTheTrackedPosesInBothModes) {
  const Scene scene;
  for (bool interpolate : {false, true}) {
    const Trajectory t =
        ResolveTrajectory(scene.records, Lookup(scene.tracked_keyframes), interpolate);
    ASSERT_EQ(t.size(), scene.records.size());
    for (size_t i = 0; i < t.size(); ++i) {
      EXPECT_DOUBLE_EQ(t[i].t, scene.records[i].stamp_s);
      EXPECT_LT((t[i].T_w_c.translation() - scene.records[i].T_w_c.translation()).norm(), 1e-12);
    }
  }
}

TEST(ResolveTrajectory, ExactImageStampsAreCarried) {
  Scene scene;
  for (size_t i = 0; i < scene.records.size(); ++i)
    scene.records[i].stamp_ns = 1403636579763555584 + static_cast<int64_t>(i) * 50000000;
  const Trajectory t = ResolveTrajectory(scene.records, Lookup(scene.tracked_keyframes), true);
  ASSERT_EQ(t.size(), scene.records.size());
  for (size_t i = 0; i < t.size(); ++i) EXPECT_EQ(t[i].t_ns, scene.records[i].stamp_ns);
}

TEST(ResolveTrajectory, FramesBlendTheCorrectionsOfTheKeyframesAroundThem) {
  const Scene scene;
  // Bundle adjustment moved keyframe 1 by +1 cm in y and keyframe 2 by +3 cm in y.
  std::map<KeyframeId, SE3> now = scene.tracked_keyframes;
  now[1] = Translation(0.0, 0.01, 0);
  now[2] = Translation(0.5, 0.03, 0);
  const Trajectory stepped = ResolveTrajectory(scene.records, Lookup(now), false);
  const Trajectory blended = ResolveTrajectory(scene.records, Lookup(now), true);
  // Following only the reference: 1 cm for frames 0-4, then a 2 cm step to 3 cm.
  EXPECT_NEAR(stepped[4].T_w_c.translation().y(), 0.01, 1e-12);
  EXPECT_NEAR(stepped[5].T_w_c.translation().y(), 0.03, 1e-12);
  // Blended: 1 cm at keyframe 1's frame, rising linearly in time to 3 cm at keyframe 2's.
  for (int i = 0; i <= 5; ++i)
    EXPECT_NEAR(blended[i].T_w_c.translation().y(), 0.01 + 0.02 * i / 5.0, 1e-9) << "frame " << i;
  // Along x nothing changed.
  for (int i = 0; i < 10; ++i) EXPECT_NEAR(blended[i].T_w_c.translation().x(), 0.1 * i, 1e-9);
  // The last run has no next keyframe: it follows keyframe 2 alone.
  for (int i = 5; i < 10; ++i) EXPECT_NEAR(blended[i].T_w_c.translation().y(), 0.03, 1e-12);
}

TEST(ResolveTrajectory, RotationCorrectionsBlendToo) {
  const Scene scene;
  std::map<KeyframeId, SE3> now = scene.tracked_keyframes;
  // Keyframe 2 turned by 2 degrees about z (a loop correction), keyframe 1 unchanged.
  const double angle = 2.0 * M_PI / 180.0;
  const SE3 turn(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                 Eigen::Vector3d::Zero());
  now[2] = turn * scene.tracked_keyframes.at(2);
  const Trajectory blended = ResolveTrajectory(scene.records, Lookup(now), true);
  auto yaw = [](const SE3& T) {
    const Eigen::Matrix3d R = T.rotation();
    return std::atan2(R(1, 0), R(0, 0));
  };
  EXPECT_NEAR(yaw(blended[0].T_w_c), 0.0, 1e-12);
  EXPECT_NEAR(yaw(blended[2].T_w_c), 0.4 * angle, 1e-9);  // 0.2 s of 0.5 s
  EXPECT_NEAR(yaw(blended[5].T_w_c), angle, 1e-12);
  // Keyframe 2's frame itself sits exactly where keyframe 2 now is.
  EXPECT_LT((blended[5].T_w_c.translation() - now[2].translation()).norm(), 1e-12);
}

TEST(ResolveTrajectory, UnknownKeyframesAndFramesBeforeTheMapKeepWhatTheyCan) {
  Scene scene;
  scene.records[0].reference = kNoId;  // tracked before the first keyframe
  std::map<KeyframeId, SE3> now;
  now[1] = Translation(0.0, 0.01, 0);  // keyframe 2 unknown (e.g. a map that was replaced)
  const Trajectory t = ResolveTrajectory(scene.records, Lookup(now), true);
  EXPECT_NEAR(t[0].T_w_c.translation().y(), 0.0, 1e-12);  // no reference: as tracked
  for (int i = 1; i < 5; ++i)  // next keyframe unknown: keyframe 1 alone, no blend
    EXPECT_NEAR(t[i].T_w_c.translation().y(), 0.01, 1e-12);
  for (int i = 5; i < 10; ++i)  // reference unknown: as tracked
    EXPECT_NEAR(t[i].T_w_c.translation().y(), 0.0, 1e-12);
  EXPECT_TRUE(ResolveTrajectory(FrameRecords(), Lookup(now), true).empty());
}

}  // namespace
}  // namespace pl_slam
