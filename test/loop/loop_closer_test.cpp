// Loop closing and relocalisation through the SlamSystem on rendered sequences with exact
// ground truth: the room's revisit is detected and every accepted loop is a true revisit,
// the global bundle adjustment after it and its follow-up lower the error (sequential; the
// follow-up over three renderings of the room) and are merged before Flush() returns
// (threaded), the corridor (no revisit) gives none, and tracking recovers after 20 blank
// frames in the same map frame, and a camera that comes back from 20 blank frames somewhere
// else in the mapped room is relocalised there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "pl_slam/eval/evaluation.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/thread_priority.h"
#include "test_util/system_options.h"

namespace pl_slam {
namespace {

SystemOptions Options() { return testing_util::SequentialWithVocabulary(); }

struct Outcome {
  LoopStats loops;
  MappingStats mapping;
  int map_keyframes = 0;
  Trajectory estimate;
  Trajectory truth;
  double ate = 0.0;  ///< SE(3)-aligned RMSE, m
};

Outcome RunScene(sim::SceneKind scene, int frames, const SystemOptions& options,
                 uint64_t world_seed = sim::SequenceOptions().world_seed) {
  sim::SequenceOptions so;
  so.scene = scene;
  so.world_seed = world_seed;
  sim::SyntheticSequence seq(so);
  SlamSystem system(seq.camera(), options);
  for (int i = 0; i < frames && i < static_cast<int>(seq.size()); ++i)
    system.Process(seq.Render(i));
  system.Flush();
  Outcome out;
  out.loops = system.loop_stats();
  out.map_keyframes = static_cast<int>(system.map().counts().keyframes);
  out.mapping = system.mapping_stats();
  out.estimate = system.trajectory();
  out.truth = seq.ground_truth();
  Trajectory gt(out.truth.begin(), out.truth.begin() + std::min<size_t>(frames, out.truth.size()));
  std::vector<double> times;
  for (const auto& s : gt) times.push_back(s.t);
  out.ate = eval::EvaluateTrajectory(out.estimate, gt, times).ate.translation.rmse;
  return out;
}

/// The room's single lap, sequential, with loop closing (computed once).
const Outcome& Room() {
  static const Outcome out = RunScene(sim::SceneKind::kRoom, 480, Options());
  return out;
}

TEST(LoopCloserTest, RoomRevisitIsDetectedAndEveryLoopIsTrue) {
  const Outcome& out = Room();
  std::cout << "room: " << out.loops.loops_detected << " loops, " << out.loops.candidates_verified
            << " candidates verified\n";
  ASSERT_GE(out.loops.loops_detected, 1);
  EXPECT_EQ(out.loops.loops_corrected, out.loops.loops_detected);
  // Culled keyframes leave the database: it holds the map's keyframes (the last one or two may
  // still be on their way), not every keyframe ever inserted.
  std::cout << "database " << out.loops.database_keyframes << " keyframes, map "
            << out.map_keyframes << ", inserted " << out.loops.keyframes_queried << "\n";
  EXPECT_LE(out.loops.database_keyframes, out.map_keyframes + 2);
  for (const LoopDetection& l : out.loops.loops) {
    // A true revisit: the two keyframes' true camera centres are close and the verified
    // relative pose agrees with the truth.
    const SE3& T_w_q = out.truth[l.query_frame].T_w_c;
    const SE3& T_w_c = out.truth[l.candidate_frame].T_w_c;
    const SE3 T_q_c_true = T_w_q.inverse() * T_w_c;
    const SE3 err = l.T_query_candidate * T_q_c_true.inverse();
    std::cout << "  loop frames " << l.query_frame << " -> " << l.candidate_frame
              << ", relative pose error " << err.translation().norm() << " m, "
              << err.RotationAngle() * 180 / M_PI << " deg\n";
    EXPECT_GT(l.query_frame - l.candidate_frame, 200) << "not a revisit";
    EXPECT_LT(err.translation().norm(), 0.05);
    EXPECT_LT(err.RotationAngle() * 180 / M_PI, 2.0);
  }
}

TEST(LoopCloserTest, GlobalBundleAdjustmentAndItsFollowUpLowerTheError) {
  const Outcome& with = Room();
  ASSERT_GE(with.loops.loops_corrected, 1);
  // Sequential: each correction's global BA runs in place and is merged, and so is its
  // follow-up loop.global_ba_followup keyframes later (the revisit is ~9 keyframes before the
  // end of the lap).
  EXPECT_EQ(with.mapping.global_ba_followups, with.loops.loops_corrected);
  EXPECT_EQ(with.mapping.global_bas, 2 * with.loops.loops_corrected);
  EXPECT_EQ(with.mapping.global_bas_discarded, 0);
  SystemOptions options = Options();
  options.loop.global_ba_followup = 0;
  const Outcome once = RunScene(sim::SceneKind::kRoom, 480, options);
  EXPECT_EQ(once.mapping.global_ba_followups, 0);
  EXPECT_EQ(once.mapping.global_bas, once.loops.loops_corrected);
  EXPECT_EQ(once.loops.loops_corrected, with.loops.loops_corrected);
  options = Options();
  options.loop.enabled = false;
  const Outcome no_loop = RunScene(sim::SceneKind::kRoom, 480, options);
  std::cout << "room ATE: no loop closing " << no_loop.ate * 1000
            << " mm, global BA at the correction only " << once.ate * 1000
            << " mm, with its follow-up " << with.ate * 1000 << " mm\n";
  // The first global BA has few observations across the loop's seam; the follow-up also has
  // the ones tracking and keyframe insertion made on the revisited part since (1.95 -> 1.45 mm
  // when the test was written). Not on every rendering of the lap: over this one and two
  // rooms of other textures, it lowers the error by their geometric mean.
  EXPECT_LT(once.ate, no_loop.ate);
  double log_ratio = std::log(with.ate / once.ate);
  for (const uint64_t world_seed : {2, 3}) {
    const Outcome w = RunScene(sim::SceneKind::kRoom, 480, Options(), world_seed);
    options = Options();
    options.loop.global_ba_followup = 0;
    const Outcome o = RunScene(sim::SceneKind::kRoom, 480, options, world_seed);
    std::cout << "room, world seed " << world_seed << ": global BA at the correction only "
              << o.ate * 1000 << " mm, with its follow-up " << w.ate * 1000 << " mm\n";
    log_ratio += std::log(w.ate / o.ate);
  }
  EXPECT_LT(log_ratio, 0.0) << "follow-up / correction only, geometric mean "
                            << std::exp(log_ratio / 3.0);
}

TEST(LoopCloserTest, ThreadedGlobalBundleAdjustmentIsMergedBeforeFlushReturns) {
  SystemOptions options = Options();
  options.mapping.threaded = true;
  const Outcome out = RunScene(sim::SceneKind::kRoom, 480, options);
  std::cout << "threaded room: " << out.loops.loops_corrected << " loops corrected, "
            << out.mapping.global_bas << " global BAs merged (" << out.mapping.global_ba_followups
            << " follow-ups), " << out.mapping.global_bas_discarded << " discarded, ATE "
            << out.ate * 1000 << " mm\n";
  ASSERT_GE(out.loops.loops_corrected, 1);
  // The last correction's global BA is never discarded: Flush() waits for it to be merged.
  EXPECT_GE(out.mapping.global_bas, 1);
  EXPECT_LE(out.mapping.global_ba_followups, out.loops.loops_corrected);
  EXPECT_EQ(out.mapping.global_bas + out.mapping.global_bas_discarded,
            out.loops.loops_corrected + out.mapping.global_ba_followups);
  EXPECT_LT(out.ate, 0.01);
  // Both background threads run below this (the tracking) thread's priority.
  const int tracking_nice = ThreadNiceValue();
  EXPECT_EQ(out.mapping.thread_nice, std::min(19, tracking_nice + options.mapping.thread_niceness));
  EXPECT_EQ(out.loops.thread_nice, std::min(19, tracking_nice + options.loop.thread_niceness));
  EXPECT_GT(options.mapping.thread_niceness, 0);  // the defaults lower them
  EXPECT_GT(options.loop.thread_niceness, 0);
}

TEST(LoopCloserTest, CorridorWithoutRevisitGivesNoLoop) {
  const Outcome out = RunScene(sim::SceneKind::kCorridor, 300, Options());
  EXPECT_EQ(out.loops.loops_detected, 0);
  EXPECT_GT(out.loops.keyframes_queried, 10);
}

TEST(LoopCloserTest, RelocalisesAfterBlankFramesInTheSameMap) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  sim::SyntheticSequence seq(so);
  SlamSystem system(seq.camera(), Options());
  const int blank_from = 100, blank_to = 120, last = 135;
  const SE3 T_gt0_inv = seq.ground_truth()[0].T_w_c.inverse();
  int recovered_at = -1;
  double error_at_recovery = 0.0;
  for (int i = 0; i <= last; ++i) {
    StereoFrame f = seq.Render(i);
    if (i >= blank_from && i < blank_to) {
      f.left.setTo(0);
      f.right.setTo(0);
    }
    const FrameResult r = system.Process(f);
    ASSERT_TRUE(r.T_w_c.IsFinite());
    if (i >= blank_from && i < blank_to) {
      EXPECT_FALSE(r.pose_valid) << "frame " << i;
      EXPECT_NE(r.state, TrackingState::kTracking) << "frame " << i;
    }
    if (i >= blank_to && recovered_at < 0 && r.pose_valid) {
      recovered_at = i;
      // The map frame is the first camera's: compare with the truth relative to frame 0.
      const SE3 truth = T_gt0_inv * seq.ground_truth()[i].T_w_c;
      error_at_recovery = (truth.translation() - r.T_w_c.translation()).norm();
    }
  }
  std::cout << "recovered at frame " << recovered_at << ", position error " << error_at_recovery
            << " m, relocalisations " << system.loop_stats().relocalizations << "\n";
  ASSERT_GE(recovered_at, blank_to);
  EXPECT_LE(recovered_at, blank_to + 5);
  EXPECT_LT(error_at_recovery, 0.05);
}

// The camera is "kidnapped": after tracking frames 0-159 the images go blank for 20 frames and
// come back showing what frame 40 saw, 120 frames (~3 m, ~90 deg) away from the last tracked
// view. Tracking from the last pose cannot recover this; relocalisation against the keyframe
// database must, in the same map frame.
TEST(LoopCloserTest, RelocalisesAKidnappedCameraInTheMappedArea) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  sim::SyntheticSequence seq(so);
  SlamSystem system(seq.camera(), Options());
  const int tracked = 160, blanks = 20, resume_at = 40, resumed = 15;
  const SE3 T_gt0_inv = seq.ground_truth()[0].T_w_c.inverse();
  const int64_t start_ns = seq.Render(0).stamp_ns;
  const int64_t period_ns = seq.Render(1).stamp_ns - start_ns;
  int step = 0;
  auto feed = [&](int sequence_frame, bool blank) {
    StereoFrame f = seq.Render(sequence_frame);
    f.index = step;
    f.stamp_ns = start_ns + step * period_ns;
    ++step;
    if (blank) {
      f.left.setTo(0);
      f.right.setTo(0);
    }
    return system.Process(f);
  };
  for (int i = 0; i < tracked; ++i) ASSERT_TRUE(feed(i, false).pose_valid) << "frame " << i;
  for (int i = 0; i < blanks; ++i) EXPECT_FALSE(feed(tracked, true).pose_valid);
  const int relocalisations_before = system.loop_stats().relocalizations;
  int recovered_after = -1;
  double error_at_recovery = 0.0;
  for (int k = 0; k < resumed; ++k) {
    const int i = resume_at + k;
    const FrameResult r = feed(i, false);
    ASSERT_TRUE(r.T_w_c.IsFinite());
    if (recovered_after < 0 && r.pose_valid) {
      recovered_after = k;
      const SE3 truth = T_gt0_inv * seq.ground_truth()[i].T_w_c;
      error_at_recovery = (truth.translation() - r.T_w_c.translation()).norm();
    }
    if (r.pose_valid) {
      // Once recovered, every pose is in the map's frame (no new map, no jump).
      const SE3 truth = T_gt0_inv * seq.ground_truth()[i].T_w_c;
      EXPECT_LT((truth.translation() - r.T_w_c.translation()).norm(), 0.05) << "frame " << i;
    }
  }
  std::cout << "kidnapped camera recovered " << recovered_after
            << " frames after the images returned, position error " << error_at_recovery
            << " m, relocalisations " << system.loop_stats().relocalizations << "\n";
  ASSERT_GE(recovered_after, 0) << "never recovered";
  EXPECT_LE(recovered_after, 5);
  EXPECT_LT(error_at_recovery, 0.05);
  EXPECT_GE(system.loop_stats().relocalizations, relocalisations_before + 1);
}

}  // namespace
}  // namespace pl_slam
