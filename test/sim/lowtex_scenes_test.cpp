// The low-texture scene family: every layout builds and renders deterministically, walks at
// walking speed clear of the walls, has the motion it promises (corner turns, the spin, the
// wall approach, the doorway), bare variants are poor in corners yet share the structure of
// the textured ones, seeds jitter the layout, and the ground-truth structural edges project
// onto image edges and disappear behind occluders.
#include "pl_slam/sim/lowtex_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "pl_slam/sim/structural_edges.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"
#include "test_util/sim_geometry.h"

namespace pl_slam::sim {
namespace {

using testing_util::DistanceToQuad;
using testing_util::WrapPi;
using testing_util::Yaw;
using testing_util::YawProfile;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad2Deg = 180.0 / kPi;

const std::vector<SceneKind> kLowtex = {SceneKind::kLowtexCorner, SceneKind::kLowtexStraight,
                                        SceneKind::kLowtexSpin,   SceneKind::kLowtexDoorway,
                                        SceneKind::kLowtexWall,   SceneKind::kLowtexOffice};

int CountFast(const cv::Mat& img) {
  std::vector<cv::KeyPoint> kps;
  cv::FAST(img, kps, 20, true);
  return static_cast<int>(kps.size());
}

SequenceOptions Options(SceneKind kind, bool bare, uint64_t world_seed = 1) {
  SequenceOptions o;
  o.scene = kind;
  o.bare = bare;
  o.world_seed = world_seed;
  return o;
}

// One textured and one bare sequence per layout (seed 1), shared by the tests.
class LowtexTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    for (SceneKind kind : kLowtex) {
      textured_[kind] = std::make_unique<SyntheticSequence>(Options(kind, false));
      bare_[kind] = std::make_unique<SyntheticSequence>(Options(kind, true));
    }
  }
  static void TearDownTestSuite() {
    textured_.clear();
    bare_.clear();
  }
  static const SyntheticSequence& Textured(SceneKind kind) { return *textured_.at(kind); }
  static const SyntheticSequence& Bare(SceneKind kind) { return *bare_.at(kind); }

  static std::map<SceneKind, std::unique_ptr<SyntheticSequence>> textured_, bare_;
};

std::map<SceneKind, std::unique_ptr<SyntheticSequence>> LowtexTest::textured_;
std::map<SceneKind, std::unique_ptr<SyntheticSequence>> LowtexTest::bare_;

TEST(LowtexSceneKindTest, NamesParseAndAreLowtex) {
  for (SceneKind kind : kLowtex) {
    EXPECT_TRUE(IsLowtexScene(kind));
    EXPECT_EQ(ParseSceneKind(SceneKindName(kind)), kind);
    EXPECT_EQ(SceneKindName(kind).rfind("lowtex_", 0), 0u);
  }
  EXPECT_FALSE(IsLowtexScene(SceneKind::kRoom));
  EXPECT_FALSE(IsLowtexScene(SceneKind::kCorridor));
  EXPECT_EQ(ParseSceneKind("lowtex_spin"), SceneKind::kLowtexSpin);
  EXPECT_EQ(AllSceneKinds().size(), 14u);
}

TEST_F(LowtexTest, LengthsAreTheWholeWalk) {
  for (SceneKind kind : kLowtex) {
    SCOPED_TRACE(SceneKindName(kind));
    const int n = LowtexDefaultNumFrames(kind, 1, 20.0);
    EXPECT_EQ(Textured(kind).size(), static_cast<std::size_t>(n));
    EXPECT_GE(n, 180);
    EXPECT_LE(n, 300);
    EXPECT_EQ(Bare(kind).size(), Textured(kind).size());
    // The walk ends at rest: the last two poses (almost) coincide.
    const Trajectory& gt = Textured(kind).ground_truth();
    EXPECT_LT((gt.back().T_w_c.translation() - gt[gt.size() - 2].T_w_c.translation()).norm(), 0.02);
  }
  // A shorter sequence is the start of the same walk.
  SequenceOptions o = Options(SceneKind::kLowtexCorner, false);
  o.num_frames = 30;
  o.width = 160;
  o.height = 120;
  o.focal = 100;
  SyntheticSequence short_seq(o);
  ASSERT_EQ(short_seq.size(), 30u);
  const Trajectory& full = Textured(SceneKind::kLowtexCorner).ground_truth();
  for (int i = 0; i < 30; ++i) {
    EXPECT_LT(
        (short_seq.ground_truth()[i].T_w_c.translation() - full[i].T_w_c.translation()).norm(),
        1e-12);
  }
}

TEST_F(LowtexTest, RenderingIsDeterministicAndDefaultsToBlurAndVignetting) {
  for (SceneKind kind : kLowtex) {
    SCOPED_TRACE(SceneKindName(kind));
    const SyntheticSequence& a = Textured(kind);
    EXPECT_DOUBLE_EQ(a.options().EffectiveBlurSigma(), 0.6);
    EXPECT_DOUBLE_EQ(a.options().EffectiveVignetting(), 0.08);
    SyntheticSequence b(Options(kind, false));  // the world is rebuilt from scratch
    const int i = static_cast<int>(a.size()) / 2;
    const StereoFrame fa = a.Render(i), fb = b.Render(i);
    EXPECT_EQ(cv::norm(fa.left, fb.left, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(fa.right, fb.right, cv::NORM_INF), 0.0);
    cv::Scalar mean, sd;
    cv::meanStdDev(fa.left, mean, sd);
    EXPECT_GT(mean[0], 60.0);
    EXPECT_LT(mean[0], 220.0);
    EXPECT_GT(sd[0], 8.0) << "frames show structure, not a flat field";
  }
}

TEST_F(LowtexTest, WalksAtWalkingSpeedClearOfSurfaces) {
  for (SceneKind kind : kLowtex) {
    SCOPED_TRACE(SceneKindName(kind));
    const SyntheticSequence& seq = Textured(kind);
    const Trajectory& gt = seq.ground_truth();
    double max_speed = 0.0, max_yaw_rate = 0.0, path = 0.0, closest = 1e9;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      const Eigen::Vector3d p = gt[i].T_w_c.translation();
      EXPECT_NEAR(p.z(), 1.5, 0.05);
      for (const TexturedQuad& q : seq.world().quads())
        closest = std::min(closest, DistanceToQuad(q, p));
      if (i % 10 == 0) {  // closed world: every axis direction hits a surface
        for (int axis = 0; axis < 3; ++axis) {
          for (double sign : {-1.0, 1.0}) {
            ASSERT_TRUE(seq.world().RayCast(p, sign * Eigen::Vector3d::Unit(axis)).hit) << i;
          }
        }
      }
      if (i == 0) continue;
      const double dt = gt[i].t - gt[i - 1].t;
      const double step = (p - gt[i - 1].T_w_c.translation()).norm();
      path += step;
      max_speed = std::max(max_speed, step / dt);
      max_yaw_rate = std::max(
          max_yaw_rate, std::abs(WrapPi(Yaw(gt[i].T_w_c) - Yaw(gt[i - 1].T_w_c))) * kRad2Deg / dt);
    }
    RecordProperty(SceneKindName(kind) + "_path_m", std::to_string(path));
    EXPECT_GT(max_speed, 0.9) << "a walk";
    EXPECT_LT(max_speed, 1.5);
    EXPECT_LT(max_yaw_rate, 110.0);
    EXPECT_GT(closest, 0.45);
    const bool corridor = kind == SceneKind::kLowtexCorner || kind == SceneKind::kLowtexStraight ||
                          kind == SceneKind::kLowtexDoorway;
    EXPECT_GT(path, corridor ? 8.0 : 5.0);
  }
}

// Z corridor: two 90-degree turns in opposite directions, each over 1.2-2.5 s, the gaze
// turning before the walk does.
TEST_F(LowtexTest, CornerTurnsNinetyDegreesTwice) {
  for (uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(seed);
    SyntheticSequence seq(Options(SceneKind::kLowtexCorner, true, seed));
    const Trajectory& gt = seq.ground_truth();
    const std::vector<double> yaw = YawProfile(gt);
    const auto extreme = std::max_element(
        yaw.begin(), yaw.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
    EXPECT_NEAR(std::abs(*extreme), 90.0, 10.0);
    EXPECT_NEAR(yaw.back(), 0.0, 10.0) << "the Z ends parallel to its start";
    // Duration of the first turn: from 10 % to 90 % of it.
    const double sign = *extreme > 0 ? 1.0 : -1.0;
    int i10 = -1, i90 = -1;
    for (std::size_t i = 0; i < yaw.size(); ++i) {
      if (i10 < 0 && sign * yaw[i] > 9.0) i10 = static_cast<int>(i);
      if (i90 < 0 && sign * yaw[i] > 81.0) i90 = static_cast<int>(i);
    }
    ASSERT_GE(i10, 0);
    ASSERT_GT(i90, i10);
    const double turn_s = gt[i90].t - gt[i10].t;
    EXPECT_GT(turn_s, 0.8);
    EXPECT_LT(turn_s, 2.5);
    // Gaze leads: half-way through the gaze's turn the walking direction has turned less.
    const int mid = (i10 + i90) / 2;
    const Eigen::Vector3d v = gt[mid + 1].T_w_c.translation() - gt[mid - 1].T_w_c.translation();
    const double walk_turned =
        std::abs(WrapPi(std::atan2(v.y(), v.x()) - Yaw(gt[0].T_w_c))) * kRad2Deg;
    EXPECT_LT(walk_turned, std::abs(yaw[mid]) - 10.0);
  }
}

TEST_F(LowtexTest, SpinTurnsOnTheSpot) {
  const Trajectory& gt = Textured(SceneKind::kLowtexSpin).ground_truth();
  const std::vector<double> yaw = YawProfile(gt);
  EXPECT_NEAR(std::abs(yaw.back()), 270.0, 10.0);
  // While the yaw goes from 30 to 240 degrees the camera stays within 0.3 m.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  int frames = 0;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    if (std::abs(yaw[i]) < 30.0 || std::abs(yaw[i]) > 240.0) continue;
    lo = lo.cwiseMin(gt[i].T_w_c.translation());
    hi = hi.cwiseMax(gt[i].T_w_c.translation());
    ++frames;
  }
  EXPECT_GT(frames, 40);
  EXPECT_LT((hi - lo).head<2>().norm(), 0.3);
}

// The wall approach comes within 0.6-1 m of a wall, which then fills the view.
TEST_F(LowtexTest, WallApproachFillsTheView) {
  for (uint64_t seed : {1, 2}) {
    SCOPED_TRACE(seed);
    SyntheticSequence seq(Options(SceneKind::kLowtexWall, true, seed));
    const Trajectory& gt = seq.ground_truth();
    double closest = 1e9;
    int closest_frame = 0;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      for (const TexturedQuad& q : seq.world().quads()) {
        if (std::abs(q.normal().z()) > 0.5) continue;  // walls only
        const double d = DistanceToQuad(q, gt[i].T_w_c.translation());
        if (d < closest) {
          closest = d;
          closest_frame = static_cast<int>(i);
        }
      }
    }
    EXPECT_LT(closest, 1.0);
    EXPECT_GT(closest, 0.5);
    const cv::Mat depth = seq.RenderDepth(closest_frame);
    cv::Mat near = (depth > 0) & (depth < 1.2f);
    EXPECT_GT(cv::countNonZero(near), 0.95 * depth.total()) << "the wall fills the view";
    EXPECT_GT(std::abs(YawProfile(gt).back()), 120.0) << "then turns away";
  }
}

TEST_F(LowtexTest, DoorwayLeadsIntoTheRoom) {
  for (uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(seed);
    SyntheticSequence seq(Options(SceneKind::kLowtexDoorway, true, seed));
    const Trajectory& gt = seq.ground_truth();
    // The corridor is |y| < 1; the room lies beyond the 12 cm wall.
    EXPECT_LT(std::abs(gt.front().T_w_c.translation().y()), 0.1);
    EXPECT_GT(std::abs(gt.back().T_w_c.translation().y()), 2.5);
    // Heading ~90 degrees from the corridor's when passing the doorway's wall (|y| = 1.06),
    // then a turn to one side in the room (back to ~0 or on to ~180).
    const std::vector<double> yaw = YawProfile(gt);
    std::size_t door = 0;
    while (door < gt.size() && std::abs(gt[door].T_w_c.translation().y()) < 1.06) ++door;
    ASSERT_LT(door, gt.size());
    EXPECT_NEAR(std::abs(yaw[door]), 90.0, 15.0);
    const double end = std::abs(yaw.back());
    EXPECT_TRUE(end < 12.0 || std::abs(end - 180.0) < 12.0) << end;
  }
}

// Bare variants: the same structure, far fewer corners. FAST corners summed over a few frames
// spread along the walk.
TEST_F(LowtexTest, BareHasTheSameStructureAndFarFewerCorners) {
  for (SceneKind kind : kLowtex) {
    SCOPED_TRACE(SceneKindName(kind));
    const SyntheticSequence& t = Textured(kind);
    const SyntheticSequence& b = Bare(kind);
    ASSERT_EQ(t.world().StructuralEdges().size(), b.world().StructuralEdges().size());
    EXPECT_GT(t.world().StructuralEdges().size(), 40u);
    for (std::size_t i = 0; i < t.world().StructuralEdges().size(); ++i) {
      ASSERT_EQ(t.world().StructuralEdges()[i].a, b.world().StructuralEdges()[i].a);
      ASSERT_EQ(t.world().StructuralEdges()[i].b, b.world().StructuralEdges()[i].b);
    }
    for (std::size_t i = 0; i < t.size(); i += 25) {
      ASSERT_EQ(t.ground_truth()[i].T_w_c.translation(), b.ground_truth()[i].T_w_c.translation());
    }
    int fast_t = 0, fast_b = 0;
    const int n = static_cast<int>(t.size());
    for (int k = 1; k <= 4; ++k) {
      const int i = k * n / 5;
      fast_t += CountFast(t.Render(i).left);
      fast_b += CountFast(b.Render(i).left);
    }
    RecordProperty(SceneKindName(kind) + "_fast_textured", fast_t / 4);
    RecordProperty(SceneKindName(kind) + "_fast_bare", fast_b / 4);
    EXPECT_LT(fast_b * 3, fast_t) << "bare " << fast_b / 4 << " vs textured " << fast_t / 4
                                  << " FAST corners per frame";
    EXPECT_LT(fast_b / 4, 150) << "bare is poor in corners";
  }
}

TEST(LowtexSeedTest, SeedsJitterTheLayout) {
  std::vector<double> ends;
  bool left = false, right = false;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    const Scene s = BuildScene(SceneKind::kLowtexCorner, 0, 20.0, 0.0, seed, 1, true);
    const Eigen::Vector3d end = s.ground_truth.back().T_w_c.translation();
    ends.push_back(end.x());
    (end.y() > 0 ? left : right) = true;
  }
  EXPECT_TRUE(left && right) << "the middle leg goes left for some seeds, right for others";
  std::sort(ends.begin(), ends.end());
  EXPECT_GT(ends.back() - ends.front(), 0.5) << "leg lengths vary";
}

// Visible structural edges lie on image edges: the intensity step across the projected
// segment is clear in the noise-free radiance for most of them.
TEST_F(LowtexTest, StructuralEdgesLieOnImageEdges) {
  for (SceneKind kind : kLowtex) {
    SCOPED_TRACE(SceneKindName(kind));
    const SyntheticSequence& seq = Bare(kind);
    int visible = 0, on_edge = 0;
    for (int i : {10, static_cast<int>(seq.size()) / 2}) {
      const auto edges = seq.VisibleStructuralEdges(i);
      const cv::Mat rad = seq.RenderGroundTruth(i).radiance;
      for (const VisibleEdge& e : edges) {
        EXPECT_TRUE(seq.camera().InImage(e.a)) << e.a.transpose();
        EXPECT_TRUE(seq.camera().InImage(e.b)) << e.b.transpose();
        EXPECT_GE(e.length(), 15.0);
        // Largest step across the segment at its quarter points, 3 px to either side.
        const Eigen::Vector2d d = (e.b - e.a).normalized(), n(-d.y(), d.x());
        double step = 0.0;
        for (double f : {0.25, 0.5, 0.75}) {
          const Eigen::Vector2d c = e.a + f * (e.b - e.a);
          const Eigen::Vector2d p = c + 3 * n, q = c - 3 * n;
          if (!seq.camera().InImage(p) || !seq.camera().InImage(q)) continue;
          const double a = rad.at<float>(std::lround(p.y()), std::lround(p.x()));
          const double b = rad.at<float>(std::lround(q.y()), std::lround(q.x()));
          step = std::max(step, std::abs(a - b));
        }
        ++visible;
        if (step > 4.0) ++on_edge;
      }
    }
    EXPECT_GT(visible, 10);
    EXPECT_GT(on_edge, 0.7 * visible) << on_edge << " of " << visible;
  }
}

// A hidden edge is not reported; an edge half behind an occluder is cut at it.
TEST(StructuralEdgesTest, OcclusionCutsEdges) {
  auto world = std::make_shared<World>();
  auto tex = std::make_shared<Texture>(cv::Mat(8, 8, CV_32F, cv::Scalar(100)));
  // Back wall at x = 4 (facing the camera looking along +x), occluder at x = 2 covering y < 0.
  world->AddQuad(MakeQuad({4, -3, 3}, {0, 6, 0}, {0, 0, -3}, tex));
  world->AddQuad(MakeQuad({2, -3, 3}, {0, 3, 0}, {0, 0, -3}, tex));
  world->AddStructuralEdge({4, -1, 1.5}, {4, 1, 1.5});     // half hidden by the occluder
  world->AddStructuralEdge({4, -2, 1.0}, {4, -0.5, 1.0});  // wholly hidden
  world->AddStructuralEdge({2, -1, 1.2}, {2, -0.2, 1.2});  // on the occluder: visible
  SequenceOptions o;
  Trajectory gt(1);
  gt[0].T_w_c = CameraPoseFromYawPitchRoll({0, 0, 1.5}, 0.0, 0.0, 0.0);
  SyntheticSequence seq(o, world, gt);
  const auto edges = seq.VisibleStructuralEdges(0);
  ASSERT_EQ(edges.size(), 2u);
  EXPECT_EQ(edges[0].edge, 0);
  EXPECT_EQ(edges[1].edge, 2);
  // The visible part of edge 0 runs from the occluder's edge (y = 0, image centre column) to
  // y = 1 at 4 m (450 * 1 / 4 = 112.5 px left of the centre).
  const double cx = seq.camera().cx;
  EXPECT_NEAR(std::max(edges[0].a.x(), edges[0].b.x()), cx, 4.0);
  EXPECT_NEAR(std::min(edges[0].a.x(), edges[0].b.x()), cx - 112.5, 3.0);
  EXPECT_NEAR(edges[0].a.y(), seq.camera().cy, 1.0);
  // Edges behind the camera or worlds without edges give nothing.
  Trajectory back(1);
  back[0].T_w_c = CameraPoseFromYawPitchRoll({0, 0, 1.5}, kPi, 0.0, 0.0);
  EXPECT_TRUE(SyntheticSequence(o, world, back).VisibleStructuralEdges(0).empty());
  SequenceOptions room;
  room.num_frames = 2;
  EXPECT_TRUE(SyntheticSequence(room).VisibleStructuralEdges(1).empty());
}

// Sensor effects: defaults leave the classic scenes untouched; blur, vignetting and the
// exposure presets do what they say.
TEST(SensorEffectsTest, BlurVignettingAndExposurePresets) {
  SequenceOptions o;
  o.scene = SceneKind::kRoom;
  o.num_frames = 12;
  o.noise_sigma = 0.0;
  EXPECT_EQ(o.EffectiveBlurSigma(), 0.0);
  EXPECT_EQ(o.EffectiveVignetting(), 0.0);
  const SyntheticSequence plain(o);
  const cv::Mat base = plain.Render(5).left;
  SequenceOptions off = o;
  off.blur_sigma = 0.0;
  off.vignetting = 0.0;
  EXPECT_EQ(cv::norm(base, SyntheticSequence(off).Render(5).left, cv::NORM_INF), 0.0);

  SequenceOptions blurred = o;
  blurred.blur_sigma = 1.0;
  auto sharpness = [](const cv::Mat& img) {
    cv::Mat lap;
    cv::Laplacian(img, lap, CV_32F);
    cv::Scalar m, sd;
    cv::meanStdDev(lap, m, sd);
    return sd[0];
  };
  EXPECT_LT(sharpness(SyntheticSequence(blurred).Render(5).left), 0.6 * sharpness(base));

  // Vignetting on a flat wall: corners lose the configured fraction, the centre nothing.
  auto world = std::make_shared<World>();
  world->AddQuad(MakeQuad({3, -10, 10}, {0, 20, 0}, {0, 0, -20},
                          std::make_shared<Texture>(cv::Mat(4, 4, CV_32F, cv::Scalar(200)))));
  Trajectory gt(1);
  gt[0].T_w_c = CameraPoseFromYawPitchRoll({0, 0, 0}, 0.0, 0.0, 0.0);
  SequenceOptions v;
  v.noise_sigma = 0.0;
  v.vignetting = 0.1;
  const cv::Mat vig = SyntheticSequence(v, world, gt).Render(0).left;
  EXPECT_NEAR(vig.at<uchar>(240, 376), 200, 1);
  EXPECT_NEAR(vig.at<uchar>(0, 0), 180, 1);
  EXPECT_NEAR(vig.at<uchar>(479, 751), 180, 1);

  SequenceOptions dim = v, bright = v;
  dim.vignetting = bright.vignetting = 0.0;
  ApplyExposurePreset("dim", &dim);
  ApplyExposurePreset("bright", &bright);
  EXPECT_EQ(dim.exposure_gain, 0.45);
  EXPECT_NEAR(SyntheticSequence(dim, world, gt).Render(0).left.at<uchar>(100, 100), 90, 1);
  EXPECT_EQ(SyntheticSequence(bright, world, gt).Render(0).left.at<uchar>(100, 100), 255)
      << "clips";
  EXPECT_THROW(ApplyExposurePreset("dark", &dim), ConfigError);
  SequenceOptions bad;
  bad.exposure_gain = 0.0;
  EXPECT_EQ(bad.Validate().rfind("exposure_gain=", 0), 0u);
  bad = SequenceOptions();
  bad.vignetting = 1.5;
  EXPECT_EQ(bad.Validate().rfind("vignetting=", 0), 0u);
}

}  // namespace
}  // namespace pl_slam::sim
