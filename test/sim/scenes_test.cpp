// The built-in scenes: lengths and stamps, trajectory shapes (closed room loop, fast yaw,
// walking speeds, clearance from every surface), image content (never empty; the corridor
// poor in corners but rich in straight lines compared with the room).
#include "pl_slam/sim/scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/line_descriptor.hpp>
#include <string>
#include <vector>

#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad2Deg = 180.0 / kPi;

// Distance from p to the rectangle of a quad.
double DistanceToQuad(const TexturedQuad& q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d rel = p - q.origin;
  const double s = std::clamp(rel.dot(q.axis_u), 0.0, q.size_u);
  const double t = std::clamp(rel.dot(q.axis_v), 0.0, q.size_v);
  return (p - q.PointAt(s, t)).norm();
}

// Heading of the optical axis in the world's horizontal plane (world z is up).
double Yaw(const SE3& T_w_c) {
  const Eigen::Vector3d z = T_w_c.rotation().col(2);
  return std::atan2(z.y(), z.x());
}

double WrapPi(double a) { return std::atan2(std::sin(a), std::cos(a)); }

class ScenesTest : public ::testing::Test {
 protected:
  // Building a world takes a few hundred ms: share one sequence per scene across tests.
  static void SetUpTestSuite() {
    for (SceneKind kind : {SceneKind::kRoom, SceneKind::kCorridor, SceneKind::kFastTurn}) {
      SequenceOptions o;
      o.scene = kind;
      sequences_[kind] = std::make_unique<SyntheticSequence>(o);
    }
  }
  static void TearDownTestSuite() { sequences_.clear(); }
  static const SyntheticSequence& Seq(SceneKind kind) { return *sequences_.at(kind); }

  static std::map<SceneKind, std::unique_ptr<SyntheticSequence>> sequences_;
};

std::map<SceneKind, std::unique_ptr<SyntheticSequence>> ScenesTest::sequences_;

TEST(SceneKindTest, ParsesNamesAndRejectsOthers) {
  for (SceneKind kind : {SceneKind::kRoom, SceneKind::kCorridor, SceneKind::kFastTurn}) {
    EXPECT_EQ(ParseSceneKind(SceneKindName(kind)), kind);
  }
  EXPECT_EQ(ParseSceneKind("fast_turn"), SceneKind::kFastTurn);
  try {
    ParseSceneKind("kitchen");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("kitchen"), std::string::npos) << what;
    EXPECT_NE(what.find("room"), std::string::npos) << what;
    EXPECT_NE(what.find("corridor"), std::string::npos) << what;
    EXPECT_NE(what.find("fast_turn"), std::string::npos) << what;
  }
}

TEST_F(ScenesTest, DefaultLengthsAndCamera) {
  EXPECT_EQ(Seq(SceneKind::kRoom).size(), 480u);
  EXPECT_EQ(Seq(SceneKind::kCorridor).size(), 300u);
  EXPECT_EQ(Seq(SceneKind::kFastTurn).size(), 200u);
  for (const auto& [kind, seq] : sequences_) {
    EXPECT_EQ(seq->ground_truth().size(), seq->size()) << SceneKindName(kind);
    const StereoCamera& cam = seq->camera();
    EXPECT_EQ(cam.width, 752);
    EXPECT_EQ(cam.height, 480);
    EXPECT_EQ(cam.fx, 450.0);
    EXPECT_EQ(cam.fy, 450.0);
    EXPECT_EQ(cam.baseline, 0.11);
    EXPECT_EQ(cam.cx, 375.5);
    EXPECT_EQ(cam.cy, 239.5);
    EXPECT_EQ(cam.Validate(), "");
  }
}

TEST(SceneLengthTest, NumFramesRateAndStartTimeAreHonoured) {
  for (SceneKind kind : {SceneKind::kRoom, SceneKind::kCorridor, SceneKind::kFastTurn}) {
    SCOPED_TRACE(SceneKindName(kind));
    SequenceOptions o;
    o.scene = kind;
    o.num_frames = 37;
    o.rate_hz = 10.0;
    o.start_time_s = 1403636579.5;
    o.width = 160;
    o.height = 120;
    o.focal = 100.0;
    SyntheticSequence seq(o);
    ASSERT_EQ(seq.size(), 37u);
    const Trajectory& gt = seq.ground_truth();
    ASSERT_EQ(gt.size(), 37u);
    EXPECT_DOUBLE_EQ(gt.front().t, 1403636579.5);
    for (std::size_t i = 1; i < gt.size(); ++i) {
      EXPECT_GT(gt[i].t, gt[i - 1].t);
      EXPECT_NEAR(gt[i].t - gt[i - 1].t, 0.1, 1e-6);
    }
    StereoFrame f;
    int n = 0;
    while (seq.Next(&f)) {
      EXPECT_EQ(f.index, n);
      EXPECT_EQ(f.stamp_ns, std::llround(gt[n].t * 1e9));
      EXPECT_EQ(f.left.size(), cv::Size(160, 120));
      ++n;
    }
    EXPECT_EQ(n, 37);
    EXPECT_FALSE(seq.Next(&f));
    seq.Rewind();
    EXPECT_TRUE(seq.Next(&f));
    EXPECT_EQ(f.index, 0);
    EXPECT_THROW(seq.Render(37), std::out_of_range);
  }
}

TEST_F(ScenesTest, StampsIncreaseAtRate) {
  for (const auto& [kind, seq] : sequences_) {
    const Trajectory& gt = seq->ground_truth();
    EXPECT_EQ(gt.front().t, 0.0);
    for (std::size_t i = 1; i < gt.size(); ++i) {
      ASSERT_GT(gt[i].t, gt[i - 1].t) << SceneKindName(kind);
      ASSERT_NEAR(gt[i].t - gt[i - 1].t, 0.05, 1e-9) << SceneKindName(kind);
    }
  }
}

TEST_F(ScenesTest, RoomLoopReturnsToItsStart) {
  const Trajectory& gt = Seq(SceneKind::kRoom).ground_truth();
  const SE3& first = gt.front().T_w_c;
  const SE3& last = gt.back().T_w_c;
  EXPECT_LT((last.translation() - first.translation()).norm(), 0.5);
  EXPECT_LT((first.inverse() * last).RotationAngle() * kRad2Deg, 20.0);
  double farthest = 0.0, turned = 0.0;
  for (std::size_t i = 1; i < gt.size(); ++i) {
    farthest = std::max(farthest, (gt[i].T_w_c.translation() - first.translation()).norm());
    turned += WrapPi(Yaw(gt[i].T_w_c) - Yaw(gt[i - 1].T_w_c));
  }
  EXPECT_GT(farthest, 2.5) << "a real loop, not standing still";
  EXPECT_NEAR(turned * kRad2Deg, 367.0, 25.0) << "one full turn round the room";
}

TEST_F(ScenesTest, MotionIsSmoothAndAtWalkingSpeed) {
  for (const auto& [kind, seq] : sequences_) {
    SCOPED_TRACE(SceneKindName(kind));
    const Trajectory& gt = seq->ground_truth();
    double max_speed = 0.0, max_yaw_rate = 0.0, max_rate = 0.0;
    for (std::size_t i = 1; i < gt.size(); ++i) {
      const double dt = gt[i].t - gt[i - 1].t;
      max_speed = std::max(max_speed,
                           (gt[i].T_w_c.translation() - gt[i - 1].T_w_c.translation()).norm() / dt);
      max_rate = std::max(
          max_rate, (gt[i - 1].T_w_c.inverse() * gt[i].T_w_c).RotationAngle() * kRad2Deg / dt);
      max_yaw_rate = std::max(
          max_yaw_rate, std::abs(WrapPi(Yaw(gt[i].T_w_c) - Yaw(gt[i - 1].T_w_c))) * kRad2Deg / dt);
    }
    EXPECT_LE(max_speed, 1.0);
    EXPECT_GT(max_speed, 0.1);
    if (kind == SceneKind::kFastTurn) {
      EXPECT_GT(max_yaw_rate, 45.0);
      EXPECT_LT(max_yaw_rate, 120.0);
      EXPECT_LT(max_speed, 0.3) << "fast turn, slow translation";
    } else {
      EXPECT_LT(max_rate, 40.0);
    }
  }
}

// No pose is inside or grazing a surface: every quad is at least 0.5 m away (so no view is a
// blurry close-up) and the camera is inside the room / corridor.
TEST_F(ScenesTest, CameraKeepsClearOfSurfaces) {
  for (const auto& [kind, seq] : sequences_) {
    SCOPED_TRACE(SceneKindName(kind));
    double closest = 1e9;
    for (const StampedPose& sp : seq->ground_truth()) {
      const Eigen::Vector3d p = sp.T_w_c.translation();
      for (const TexturedQuad& q : seq->world().quads())
        closest = std::min(closest, DistanceToQuad(q, p));
      // Every direction from the camera hits a surface (the world is closed around it).
      for (int axis = 0; axis < 3; ++axis) {
        for (double sign : {-1.0, 1.0}) {
          ASSERT_TRUE(seq->world().RayCast(p, sign * Eigen::Vector3d::Unit(axis)).hit);
        }
      }
    }
    EXPECT_GT(closest, 0.5);
  }
}

// Along each whole default trajectory (subsampled), both images have sensible brightness and
// contrast: no black, saturated or flat frames.
TEST_F(ScenesTest, FramesAreNeverEmpty) {
  for (const auto& [kind, seq] : sequences_) {
    SCOPED_TRACE(SceneKindName(kind));
    const int n = static_cast<int>(seq->size());
    for (int i = 0; i < n; i += n / 6) {
      const StereoFrame f = seq->Render(i);
      for (const cv::Mat* img : {&f.left, &f.right}) {
        ASSERT_EQ(img->type(), CV_8UC1);
        cv::Scalar mean, sd;
        cv::meanStdDev(*img, mean, sd);
        EXPECT_GT(mean[0], 50.0) << "frame " << i;
        EXPECT_LT(mean[0], 210.0) << "frame " << i;
        EXPECT_GT(sd[0], 15.0) << "frame " << i;
        EXPECT_GT(cv::countNonZero(*img), 0.99 * img->total()) << "frame " << i;
      }
    }
  }
}

int CountFast(const cv::Mat& img) {
  std::vector<cv::KeyPoint> kps;
  cv::FAST(img, kps, 20, true);
  return static_cast<int>(kps.size());
}

int CountCorners(const cv::Mat& img) {
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(img, corners, 5000, 0.01, 5.0);
  return static_cast<int>(corners.size());
}

int CountLongLines(const cv::Mat& img, double min_length) {
  cv::Ptr<cv::line_descriptor::LSDDetector> lsd =
      cv::line_descriptor::LSDDetector::createLSDDetector();
  std::vector<cv::line_descriptor::KeyLine> lines;
  lsd->detect(img, lines, 2, 1);
  return static_cast<int>(std::count_if(lines.begin(), lines.end(),
                                        [&](const auto& l) { return l.lineLength >= min_length; }));
}

// The corridor is the "low texture, line-rich" case: far fewer corners than the room, yet
// plenty of long straight segments.
TEST_F(ScenesTest, CorridorHasFewCornersButManyLines) {
  double room_fast = 0, corridor_fast = 0, room_gftt = 0, corridor_gftt = 0;
  int corridor_lines_min = 1 << 30;
  const int frames = 3;
  for (int k = 0; k < frames; ++k) {
    const StereoFrame room = Seq(SceneKind::kRoom).Render(40 + 150 * k);
    const StereoFrame corridor = Seq(SceneKind::kCorridor).Render(20 + 120 * k);
    room_fast += CountFast(room.left);
    corridor_fast += CountFast(corridor.left);
    room_gftt += CountCorners(room.left);
    corridor_gftt += CountCorners(corridor.left);
    corridor_lines_min = std::min(corridor_lines_min, CountLongLines(corridor.left, 30.0));
  }
  RecordProperty("room_fast", room_fast / frames);
  RecordProperty("corridor_fast", corridor_fast / frames);
  EXPECT_GT(room_fast / frames, 500.0) << "the room is richly textured";
  EXPECT_LT(corridor_fast * 10, room_fast)
      << "corridor " << corridor_fast / frames << " FAST corners vs room " << room_fast / frames;
  EXPECT_LT(corridor_gftt * 4, room_gftt) << "corridor " << corridor_gftt / frames
                                          << " Shi-Tomasi corners vs room " << room_gftt / frames;
  EXPECT_GE(corridor_lines_min, 25) << "door frames, skirting, panel joints, light strips";
}

}  // namespace
}  // namespace pl_slam::sim
