// Local mapping through the SlamSystem on rendered sequences with exact ground truth:
// the sequential mode is deterministic, a queued keyframe moves with its anchor, mapping beats
// visual odometry alone, keyframes come whenever mapping is idle, culling spares the newest
// keyframes, the threaded mode processes every keyframe it accepts, and bad options are refused by
// name.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "pl_slam/eval/evaluation.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/mapping/local_mapper.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/tracking/stereo_tracker.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/thread_priority.h"

namespace pl_slam {
namespace {

struct Frames {
  StereoCamera camera;
  std::vector<StereoFrame> frames;
  Trajectory ground_truth;
  std::vector<double> times;
};

/// The first n frames of a rendered scene (cached per scene).
const Frames& Scene(sim::SceneKind kind, int n) {
  static std::map<sim::SceneKind, Frames> caches;
  Frames& cache = caches[kind];
  if (static_cast<int>(cache.frames.size()) < n) {
    sim::SequenceOptions so;
    so.scene = kind;
    sim::SyntheticSequence seq(so);
    cache = Frames();
    cache.camera = seq.camera();
    for (int i = 0; i < n; ++i) {
      cache.frames.push_back(seq.Render(i));
      cache.ground_truth.push_back(seq.ground_truth()[i]);
      cache.times.push_back(cache.ground_truth.back().t);
    }
  }
  return cache;
}

const Frames& Room(int n) { return Scene(sim::SceneKind::kRoom, n); }

struct RunOutcome {
  Trajectory trajectory;
  MapCounts counts;
  MappingStats stats;
  int keyframes_flagged = 0;
  double ate = 0.0;
};

RunOutcome RunSystem(const SystemOptions& options, int n,
                     sim::SceneKind kind = sim::SceneKind::kRoom) {
  const Frames& data = Scene(kind, n);
  SlamSystem system(data.camera, options);
  RunOutcome run;
  for (int i = 0; i < n; ++i) {
    const FrameResult r = system.Process(data.frames[i]);
    EXPECT_TRUE(r.T_w_c.IsFinite());
    run.keyframes_flagged += r.is_keyframe;
  }
  system.Flush();
  run.trajectory = system.trajectory();
  run.counts = system.map().counts();
  run.stats = system.mapping_stats();
  Trajectory gt(data.ground_truth.begin(), data.ground_truth.begin() + n);
  std::vector<double> times(data.times.begin(), data.times.begin() + n);
  run.ate = eval::EvaluateTrajectory(run.trajectory, gt, times).ate.translation.rmse;
  return run;
}

SystemOptions Sequential() {
  SystemOptions o;
  o.mapping.threaded = false;
  return o;
}

TEST(LocalMapperTest, SequentialModeIsBitIdentical) {
  const RunOutcome a = RunSystem(Sequential(), 60);
  const RunOutcome b = RunSystem(Sequential(), 60);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].T_w_c.matrix(), b.trajectory[i].T_w_c.matrix())
        << "frame " << i << " differs by "
        << (a.trajectory[i].T_w_c.matrix() - b.trajectory[i].T_w_c.matrix()).norm();
  }
  EXPECT_EQ(a.counts.points, b.counts.points);
  EXPECT_EQ(a.counts.lines, b.counts.lines);
  EXPECT_GT(a.counts.keyframes, 3u);
  EXPECT_GT(a.counts.points, 100u);
  EXPECT_GT(a.counts.lines, 10u);
}

// The fast turn (545 deg over 1.6 m) is where visual odometry drifts most. With the map the
// error is lower than visual odometry's, whether or not VO refines its poses against the
// last keyframe (tracker.track_keyframe). On slow, smooth parts (the room's first 240
// frames) keyframe-refined VO is as accurate as the map; docs/BENCHMARKS.md has both.
TEST(LocalMapperTest, MappingBeatsVisualOdometryAlone) {
  const auto kFastTurn = sim::SceneKind::kFastTurn;
  SystemOptions vo = Sequential();
  vo.mapping.enabled = false;
  const RunOutcome without = RunSystem(vo, 200, kFastTurn);
  vo.tracker.track_keyframe = false;
  const RunOutcome chain = RunSystem(vo, 200, kFastTurn);
  const RunOutcome with = RunSystem(Sequential(), 200, kFastTurn);
  std::cout << "fast_turn 200 frames: ATE VO " << without.ate << " m (frame-to-frame only "
            << chain.ate << " m), with mapping " << with.ate << " m, " << with.counts.keyframes
            << " keyframes, " << with.counts.points << " points, " << with.counts.lines
            << " lines, BA median "
            << (with.stats.ba_ms.empty() ? 0.0 : with.stats.ba_ms[with.stats.ba_ms.size() / 2])
            << " ms\n";
  EXPECT_EQ(with.trajectory.size(), 200u);
  EXPECT_LT(with.ate, 0.9 * without.ate);
  EXPECT_LT(with.ate, 0.6 * chain.ate);
  EXPECT_LT(with.ate, 0.005);
  EXPECT_EQ(without.counts.keyframes, 0u);
}

// mapping.align_points (on by default): the observations of landmarks made in earlier
// keyframes are moved to where the landmark's reference patch aligns, by under 2.5 px, most by
// a fraction of a pixel; a landmark's own reference observation stays where it was detected.
// Off, nothing moves.
TEST(LocalMapperTest, PointObservationsAreAlignedToTheLandmarksFirstView) {
  for (const bool align : {true, false}) {
    SystemOptions o = Sequential();
    o.mapping.align_points = align;
    const Frames& data = Room(120);
    SlamSystem system(data.camera, o);
    for (const StereoFrame& f : data.frames) system.Process(f);
    system.Flush();
    const Map& map = system.map();
    auto lock = map.Lock();
    int observations = 0, aligned = 0, references_moved = 0;
    std::vector<double> moves;
    for (const auto& [id, kf] : map.KeyframesLocked()) {
      for (size_t j = 0; j < kf->point_landmarks.size(); ++j) {
        const auto p = map.PointLocked(kf->point_landmarks[j]);
        if (!p) continue;
        const double move =
            j < kf->point_offsets.size() ? kf->point_offsets[j].cast<double>().norm() : 0.0;
        if (p->reference == id) {
          references_moved += move > 0.0;
          continue;
        }
        ++observations;
        if (move > 0.0) {
          ++aligned;
          moves.push_back(move);
        }
      }
    }
    ASSERT_GT(observations, 1000);
    EXPECT_EQ(references_moved, 0);
    if (!align) {
      EXPECT_EQ(aligned, 0);
      continue;
    }
    std::sort(moves.begin(), moves.end());
    std::cout << aligned << " of " << observations << " observations aligned, median move "
              << moves[moves.size() / 2] << " px, largest " << moves.back() << " px\n";
    // Views that would warp the patch by over 8 % are left alone: about a fifth is aligned.
    EXPECT_GT(aligned, observations / 10);
    EXPECT_LE(moves.back(), 2.5);
    EXPECT_LT(moves[moves.size() / 2], 1.0);
  }
}

// Keyframes whenever local mapping is idle (tracker.keyframes.idle_min_frames, ORB-SLAM's rule,
// off by default): in sequential mode mapping is always idle, so every frame that moved is
// proposed, and culling thins them later. On the fast turn that gives more keyframes and a
// lower error than the entropy and safety triggers alone; visual odometry alone (no mapping)
// is not affected.
TEST(LocalMapperTest, KeyframesWhenMappingIsIdle) {
  const auto kFastTurn = sim::SceneKind::kFastTurn;
  constexpr int kFrames = 200;
  SystemOptions o = Sequential();
  o.loop.enabled = false;
  EXPECT_EQ(o.tracker.keyframes.idle_min_frames, 0);  // the default: off
  SystemOptions off = o;
  o.tracker.keyframes.idle_min_frames = 1;
  const RunOutcome idle = RunSystem(o, kFrames, kFastTurn);
  const RunOutcome triggers_only = RunSystem(off, kFrames, kFastTurn);
  std::cout << "fast_turn: keyframes when mapping is idle " << idle.ate * 1e3 << " mm, "
            << idle.stats.keyframes_processed << " keyframes (" << idle.counts.keyframes
            << " kept); entropy and safety triggers only " << triggers_only.ate * 1e3 << " mm, "
            << triggers_only.stats.keyframes_processed << " keyframes\n";
  EXPECT_GT(idle.stats.keyframes_processed, triggers_only.stats.keyframes_processed);
  EXPECT_LT(idle.ate, 0.9 * triggers_only.ate);

  o.mapping.enabled = false;
  off.mapping.enabled = false;
  const RunOutcome vo = RunSystem(o, kFrames, kFastTurn);
  const RunOutcome vo_off = RunSystem(off, kFrames, kFastTurn);
  ASSERT_EQ(vo.trajectory.size(), vo_off.trajectory.size());
  for (size_t i = 0; i < vo.trajectory.size(); ++i)
    ASSERT_EQ(vo.trajectory[i].T_w_c.matrix(), vo_off.trajectory[i].T_w_c.matrix()) << i;
  EXPECT_EQ(vo.keyframes_flagged, vo_off.keyframes_flagged);
}

// Lines only, the corridor makes a keyframe at almost every frame (fewer than 40 inliers), and
// each new keyframe sees most landmarks of the few before it. Culling those as soon as that
// happens leaves about 20 of 250 keyframes and 7 times the ATE (10.4 against 1.5 mm); keeping
// the newest (mapping.cull_keep_newest) still culls most keyframes once they are behind the
// camera. (Lines-only visual odometry reaches 1.1 mm here: the map does not beat it.)
TEST(LocalMapperTest, CullingKeepsTheNewestKeyframes) {
  const auto kCorridor = sim::SceneKind::kCorridor;
  constexpr int kFrames = 300;
  SystemOptions o = Sequential();
  o.tracker.mode = FeatureMode::kLines;
  o.loop.enabled = false;
  SystemOptions vo = o;
  vo.mapping.enabled = false;
  const RunOutcome odometry = RunSystem(vo, kFrames, kCorridor);
  SystemOptions eager = o;
  eager.mapping.cull_keep_newest = 0;
  const RunOutcome culled_early = RunSystem(eager, kFrames, kCorridor);
  const RunOutcome kept = RunSystem(o, kFrames, kCorridor);
  auto describe = [](const RunOutcome& r) {
    return std::to_string(r.ate * 1e3) + " mm, " + std::to_string(r.counts.keyframes) + " of " +
           std::to_string(r.stats.keyframes_processed) + " keyframes";
  };
  std::cout << "corridor, lines only: VO " << odometry.ate * 1e3 << " mm; map, newest culled "
            << describe(culled_early) << "; newest 20 kept " << describe(kept) << "\n";
  EXPECT_EQ(kept.trajectory.size(), static_cast<size_t>(kFrames));
  EXPECT_LT(kept.ate, 0.5 * culled_early.ate);
  EXPECT_LT(kept.ate, 0.002);
  // Culling still bounds the map: most keyframes go.
  EXPECT_GT(kept.stats.keyframes_culled, kept.stats.keyframes_processed / 2);
  EXPECT_GE(kept.counts.keyframes, 20u);
}

// mapping.ba.line_residual=auto measures lines-only bundle adjustment with the observed
// segment's endpoints (distances to the projected 3D line), which does not depend on where a
// landmark's endpoints sit along its line: 1.7 against 1.9 mm on the benchmark's corridor, and
// better on every benchmark sequence in lines-only mode, with the segments stereo crossing
// gives depth. Flat segments with depth from their junctions (the default) make both forms
// better and the two closer: observed 1.3 against projected 1.1 mm on this corridor, 0.95x
// projected's ATE over eight renderings (corridor seeds 1-6, its default and the room), which
// is why auto still chooses it; the margin checked here is the one without them. With points
// it stays the paper's form.
TEST(LocalMapperTest, LinesOnlyModeUsesTheObservedEndpointResidual) {
  const auto kCorridor = sim::SceneKind::kCorridor;
  SystemOptions o = Sequential();
  o.tracker.mode = FeatureMode::kLines;
  o.tracker.line_matching.junction_max_px = 0.0;
  o.loop.enabled = false;
  const RunOutcome automatic = RunSystem(o, 300, kCorridor);
  o.mapping.ba.line_residual = "observed";
  const RunOutcome observed = RunSystem(o, 300, kCorridor);
  o.mapping.ba.line_residual = "projected";
  const RunOutcome projected = RunSystem(o, 300, kCorridor);
  std::cout << "corridor, lines only: observed " << observed.ate * 1e3 << " mm, projected "
            << projected.ate * 1e3 << " mm\n";
  EXPECT_EQ(automatic.ate, observed.ate);
  EXPECT_LT(observed.ate, 0.9 * projected.ate);
  // Points and lines: auto is the paper's form.
  SystemOptions pl = Sequential();
  pl.loop.enabled = false;
  const RunOutcome pl_auto = RunSystem(pl, 120, kCorridor);
  pl.mapping.ba.line_residual = "projected";
  EXPECT_EQ(pl_auto.ate, RunSystem(pl, 120, kCorridor).ate);
  pl.mapping.ba.line_residual = "observed";
  EXPECT_NE(pl_auto.ate, RunSystem(pl, 120, kCorridor).ate);
}

TEST(LocalMapperTest, ThreadedModeProcessesEveryAcceptedKeyframe) {
  const RunOutcome run = RunSystem(SystemOptions(), 80);
  EXPECT_EQ(run.stats.queue_length, 0);
  EXPECT_EQ(run.stats.keyframes_processed + run.stats.keyframes_dropped, run.keyframes_flagged);
  EXPECT_EQ(run.counts.keyframes + run.stats.keyframes_culled,
            static_cast<size_t>(run.stats.keyframes_processed));
  EXPECT_LT(run.ate, 0.015);
  EXPECT_EQ(run.stats.thread_nice, std::min(19, ThreadNiceValue() + 10));  // the default
}

// A keyframe made while mapping moved its anchor (a loop correction while it was queued)
// enters the map moved with the anchor. The correction (1 m, 8 deg, as a long loop's) is beyond
// what refining against the previous keyframe may apply: without the anchor, the keyframe's
// bundle adjustment pulls it only part of the way towards the map it sees (7.7 cm off).
TEST(LocalMapperTest, AQueuedKeyframeMovesWithItsAnchor) {
  const Frames& data = Room(6);
  MappingOptions mo;
  mo.threaded = false;
  const SE3 C(Eigen::AngleAxisd(8.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
              Eigen::Vector3d(0.6, -0.4, 0.69));
  auto run = [&](bool with_anchor) {
    Map map;
    LocalMapper mapper(data.camera, mo, MappingFrontEnd(), &map);
    StereoTracker tracker(data.camera, TrackerOptions());
    const SE3 T0 = data.ground_truth[0].T_w_c, T5 = data.ground_truth[5].T_w_c;
    tracker.Track(data.frames[0]);
    KeyframeInput first;
    first.id = 0;
    first.T_w_c = T0;
    first.features = tracker.last_features();
    EXPECT_TRUE(mapper.Submit(std::move(first)));
    {  // the correction, as loop closing applies it: the keyframe and its landmarks
      auto lock = map.Lock();
      for (const auto& [id, kf] : map.KeyframesLocked()) kf->T_w_c = C * kf->T_w_c;
      for (const auto& [id, p] : map.PointsLocked()) p->p_w = C * p->p_w;
      for (const auto& [id, l] : map.LinesLocked()) {
        l->P_w = C * l->P_w;
        l->Q_w = C * l->Q_w;
      }
      map.TouchLocked();
    }
    for (int i = 1; i <= 5; ++i) tracker.Track(data.frames[i]);
    KeyframeInput second;  // tracked in the frame before the correction
    second.id = 1;
    second.T_w_c = T5;
    if (with_anchor) {
      second.anchor = 0;
      second.T_w_anchor = T0;
    }
    second.features = tracker.last_features();
    EXPECT_TRUE(mapper.Submit(std::move(second)));
    SE3 T;
    EXPECT_TRUE(map.KeyframePose(1, &T));
    return (C * T5).inverse() * T;  // error against where the corrected map has it
  };
  const SE3 anchored = run(true), unanchored = run(false);
  std::cout << "keyframe made before a 1 m / 8 deg correction, off from the corrected map: "
            << "with its anchor " << anchored.translation().norm() * 1000 << " mm, "
            << anchored.RotationAngle() * 180.0 / M_PI << " deg; without "
            << unanchored.translation().norm() * 1000 << " mm" << std::endl;
  EXPECT_LT(anchored.translation().norm(), 0.01);
  EXPECT_LT(anchored.RotationAngle() * 180.0 / M_PI, 0.2);
  EXPECT_GT(unanchored.translation().norm(), 0.03);
}

/// The system refuses `o` with a ConfigError naming `key_value` (e.g. "mapping.window=1").
void ExpectRefused(const SystemOptions& o, const std::string& key_value) {
  try {
    SlamSystem system(Room(1).camera, o);
    ADD_FAILURE() << key_value << " accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(key_value), std::string::npos) << e.what();
  }
}

TEST(LocalMapperTest, InvalidOptionsAreRefusedByName) {
  SystemOptions o;
  o.mapping.window = 1;
  ExpectRefused(o, "mapping.window=1");
  o = SystemOptions();
  o.mapping.ba.max_iterations = 0;
  EXPECT_THROW(SlamSystem(Room(1).camera, o), ConfigError);
  o = SystemOptions();
  o.mapping.cull_keep_newest = -1;
  ExpectRefused(o, "mapping.cull_keep_newest=-1");
  o = SystemOptions();
  o.mapping.thread_niceness = 20;
  ExpectRefused(o, "mapping.thread_niceness=20");
  o = SystemOptions();
  o.loop.thread_niceness = -1;
  ExpectRefused(o, "loop.thread_niceness=-1");
  o = SystemOptions();
  o.tracker.keyframes.idle_min_frames = -1;
  ExpectRefused(o, "tracker.keyframes.idle_min_frames=-1");
  o = SystemOptions();
  o.mapping.ba.line_residual = "endpoints";
  ExpectRefused(o, "line_residual='endpoints'");
}

}  // namespace
}  // namespace pl_slam
