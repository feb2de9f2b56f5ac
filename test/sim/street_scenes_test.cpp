// The street scene family: the KITTI-like camera is the scenes' default, every layout drives
// its whole route at car speed with the camera 1.65 m above the road and turns as it
// promises, seeds change the layout, and rendered frames show structure (gradients, corners,
// structural edges, the road plane at its true depth) under a plain, depthless sky.
#include "pl_slam/sim/street_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "pl_slam/sim/lowtex_scenes.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "test_util/sim_geometry.h"

namespace pl_slam::sim {
namespace {

using testing_util::DistanceToQuad;
using testing_util::WrapPi;
using testing_util::Yaw;
using testing_util::YawProfile;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad2Deg = 180.0 / kPi;

const std::vector<SceneKind> kStreet = {SceneKind::kStreetStraight, SceneKind::kStreetCurve,
                                        SceneKind::kStreetJunction, SceneKind::kStreetAvenue,
                                        SceneKind::kStreetSBend};

TEST(StreetSceneKindTest, NamesParseAndDefaultToTheCarCamera) {
  for (SceneKind kind : kStreet) {
    SCOPED_TRACE(SceneKindName(kind));
    EXPECT_TRUE(IsStreetScene(kind));
    EXPECT_FALSE(IsLowtexScene(kind));
    EXPECT_EQ(ParseSceneKind(SceneKindName(kind)), kind);
    EXPECT_EQ(SceneKindName(kind).rfind("street_", 0), 0u);
    const SequenceOptions o = DefaultSequenceOptions(kind);
    EXPECT_EQ(o.scene, kind);
    EXPECT_EQ(o.width, 1241);
    EXPECT_EQ(o.height, 376);
    EXPECT_DOUBLE_EQ(o.focal, 718.856);
    EXPECT_DOUBLE_EQ(o.baseline, 0.54);
    EXPECT_DOUBLE_EQ(o.rate_hz, 10.0);
    EXPECT_DOUBLE_EQ(o.EffectiveBlurSigma(), 0.6);
    EXPECT_DOUBLE_EQ(o.EffectiveVignetting(), 0.08);
    EXPECT_EQ(DefaultNumFrames(kind), StreetDefaultNumFrames(kind, 7, 10.0));
  }
  EXPECT_FALSE(IsStreetScene(SceneKind::kRoom));
  EXPECT_FALSE(IsStreetScene(SceneKind::kLowtexCorner));
  const SequenceOptions room = DefaultSequenceOptions(SceneKind::kRoom);
  EXPECT_EQ(room.width, SequenceOptions().width);
  EXPECT_DOUBLE_EQ(room.baseline, SequenceOptions().baseline);
  EXPECT_THROW(StreetGroundTruth(SceneKind::kRoom, 10, 10.0, 0.0, 1), std::invalid_argument);
}

TEST(StreetTrajectoryTest, DrivesTheWholeRouteAtCarSpeedAndCameraHeight) {
  for (SceneKind kind : kStreet) {
    for (uint64_t seed : {1, 2, 3}) {
      SCOPED_TRACE(SceneKindName(kind) + " seed " + std::to_string(seed));
      const Trajectory gt = StreetGroundTruth(kind, 0, 10.0, 0.0, seed);
      EXPECT_EQ(static_cast<int>(gt.size()), StreetDefaultNumFrames(kind, seed, 10.0));
      EXPECT_GE(gt.size(), 300u);
      EXPECT_LE(gt.size(), 420u);
      std::vector<double> speeds;
      double max_tilt = 0.0;
      for (std::size_t i = 0; i < gt.size(); ++i) {
        const Eigen::Vector3d p = gt[i].T_w_c.translation();
        EXPECT_NEAR(p.z(), kStreetCameraHeight, 0.02);
        // Optical y axis (image down) stays within a degree of the world's down.
        const Eigen::Vector3d y = gt[i].T_w_c.rotation().col(1);
        max_tilt = std::max(max_tilt, std::acos(std::clamp(-y.z(), -1.0, 1.0)) * kRad2Deg);
        if (i > 0) {
          const double dt = gt[i].t - gt[i - 1].t;
          speeds.push_back((p - gt[i - 1].T_w_c.translation()).norm() / dt);
        }
      }
      EXPECT_LT(max_tilt, 1.0);
      std::sort(speeds.begin(), speeds.end());
      EXPECT_GT(speeds.front(), 4.5) << "slowest (junction turns: 5-7 m/s)";
      EXPECT_LT(speeds.back(), 15.5);
      const double median = speeds[speeds.size() / 2];
      EXPECT_GT(median, 8.0);
      EXPECT_LT(median, 15.0);
    }
  }
}

TEST(StreetTrajectoryTest, LayoutsTurnAsTheyPromiseAndSeedsChangeThem) {
  for (uint64_t seed : {1, 2, 3, 4}) {
    SCOPED_TRACE(seed);
    auto profile = [seed](SceneKind kind) {
      return YawProfile(StreetGroundTruth(kind, 0, 10.0, 0.0, seed));
    };
    auto max_abs = [](const std::vector<double>& v) {
      double m = 0.0;
      for (double x : v) m = std::max(m, std::abs(x));
      return m;
    };
    EXPECT_LT(max_abs(profile(SceneKind::kStreetStraight)), 3.0);
    EXPECT_LT(max_abs(profile(SceneKind::kStreetAvenue)), 3.0);
    const std::vector<double> curve = profile(SceneKind::kStreetCurve);
    EXPECT_GT(std::abs(curve.back()), 55.0);
    EXPECT_LT(std::abs(curve.back()), 95.0);
    const std::vector<double> junction = profile(SceneKind::kStreetJunction);
    EXPECT_NEAR(std::abs(junction.back()), 90.0, 4.0);
    // The junction turn is sharp: from 10 to 80 degrees within 6 s (60 frames).
    const auto at = [&](double deg) {
      return std::find_if(junction.begin(), junction.end(),
                          [deg](double y) { return std::abs(y) >= deg; }) -
             junction.begin();
    };
    EXPECT_LT(at(80.0) - at(10.0), 60);
    const std::vector<double> s_bend = profile(SceneKind::kStreetSBend);
    EXPECT_GT(max_abs(s_bend), 30.0);
    EXPECT_LT(std::abs(s_bend.back()), 8.0) << "the second bend undoes the first";
  }
  for (SceneKind kind : kStreet) {
    SCOPED_TRACE(SceneKindName(kind));
    const Trajectory a = StreetGroundTruth(kind, 0, 10.0, 0.0, 1);
    const Trajectory b = StreetGroundTruth(kind, 0, 10.0, 0.0, 2);
    EXPECT_GT((a.back().T_w_c.translation() - b.back().T_w_c.translation()).norm(), 1.0);
    // A shorter sequence is the start of the same drive, at any rate.
    const Trajectory head = StreetGroundTruth(kind, 25, 10.0, 0.0, 1);
    ASSERT_EQ(head.size(), 25u);
    for (int i = 0; i < 25; ++i) {
      EXPECT_LT((head[i].T_w_c.translation() - a[i].T_w_c.translation()).norm(), 1e-12);
    }
  }
}

// One junction world (the layout with the most to see), rendered at a few frames.
class StreetRenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SequenceOptions o = DefaultSequenceOptions(SceneKind::kStreetJunction);
    o.world_seed = 1;
    seq_ = std::make_unique<SyntheticSequence>(o);
  }
  static void TearDownTestSuite() { seq_.reset(); }
  static std::unique_ptr<SyntheticSequence> seq_;
};

std::unique_ptr<SyntheticSequence> StreetRenderTest::seq_;

TEST_F(StreetRenderTest, CameraAndImagesAreKittiLike) {
  const StereoCamera& cam = seq_->camera();
  EXPECT_EQ(cam.width, 1241);
  EXPECT_EQ(cam.height, 376);
  EXPECT_DOUBLE_EQ(cam.fx, 718.856);
  EXPECT_DOUBLE_EQ(cam.baseline, 0.54);
  EXPECT_EQ(seq_->size(),
            static_cast<std::size_t>(StreetDefaultNumFrames(SceneKind::kStreetJunction, 1, 10.0)));
  EXPECT_NEAR(
      (seq_->RightPose(5).translation() - seq_->ground_truth()[5].T_w_c.translation()).norm(), 0.54,
      1e-9);
  const StereoFrame f = seq_->Render(0);
  EXPECT_EQ(f.left.cols, 1241);
  EXPECT_EQ(f.left.rows, 376);
  EXPECT_EQ(f.left.type(), CV_8UC1);
  EXPECT_EQ(f.right.size(), f.left.size());
}

TEST_F(StreetRenderTest, FramesHaveStructureUnderAPlainSky) {
  const int n = static_cast<int>(seq_->size());
  for (int i : {0, n / 3, n / 2, n - 1}) {
    SCOPED_TRACE(i);
    const StereoFrame f = seq_->Render(i);
    const RenderedView truth = seq_->RenderGroundTruth(i);
    // Structure: strong mean gradient and many corners over the image.
    cv::Mat gx, gy, mag;
    cv::Sobel(f.left, gx, CV_32F, 1, 0);
    cv::Sobel(f.left, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, mag);
    const double mean_gradient = cv::mean(mag)[0];
    std::vector<cv::KeyPoint> corners;
    cv::FAST(f.left, corners, 20, true);
    RecordProperty("frame" + std::to_string(i) + "_corners", static_cast<int>(corners.size()));
    EXPECT_GT(mean_gradient, 25.0);
    EXPECT_GT(corners.size(), 400u);
    // Sky: pixels that see nothing have no depth; inside them (away from their border) the
    // image is flat, and no corner is found there.
    cv::Mat sky = truth.depth == 0.0f;
    const double sky_fraction = cv::countNonZero(sky) / static_cast<double>(sky.total());
    EXPECT_GT(sky_fraction, 0.01) << "open sky over the street";
    EXPECT_LT(sky_fraction, 0.4);
    cv::Mat inner;
    cv::erode(sky, inner, cv::Mat::ones(9, 9, CV_8U));
    if (cv::countNonZero(inner) > 100) {
      EXPECT_LT(cv::mean(mag, inner)[0], 12.0) << "sky gradients are noise only";
      for (const cv::KeyPoint& kp : corners) {
        EXPECT_EQ(inner.at<uint8_t>(cvRound(kp.pt.y), cvRound(kp.pt.x)), 0)
            << "corner in the sky at " << kp.pt;
      }
    }
    cv::Mat bottom_sky = sky.rowRange(sky.rows / 2, sky.rows);
    EXPECT_EQ(cv::countNonZero(bottom_sky), 0) << "below the horizon every ray hits something";
    // The road at the bottom centre lies at the depth of a plane 1.65 m below the camera.
    const int v = f.left.rows - 1;
    const double expected = kStreetCameraHeight * seq_->camera().fy / (v - seq_->camera().cy);
    EXPECT_NEAR(truth.depth.at<float>(v, f.left.cols / 2), expected, 0.5);
    // Ground-truth structural edges are in view.
    EXPECT_GT(seq_->VisibleStructuralEdges(i).size(), 50u);
  }
}

TEST_F(StreetRenderTest, DriveKeepsClearOfEverySurface) {
  const Trajectory& gt = seq_->ground_truth();
  double closest = 1e9;
  for (std::size_t i = 0; i < gt.size(); i += 2) {
    const Eigen::Vector3d p = gt[i].T_w_c.translation();
    for (const TexturedQuad& q : seq_->world().quads()) {
      if (std::abs(q.normal().z()) > 0.99 && q.origin.z() == 0.0) continue;  // the road
      closest = std::min(closest, DistanceToQuad(q, p));
    }
    EXPECT_FALSE(seq_->world().RayCast(p, Eigen::Vector3d::UnitZ()).hit) << "open sky at " << i;
    EXPECT_TRUE(seq_->world().RayCast(p, -Eigen::Vector3d::UnitZ()).hit) << "road under " << i;
  }
  RecordProperty("closest_m", std::to_string(closest));
  EXPECT_GT(closest, 1.2);
}

TEST_F(StreetRenderTest, RenderingIsDeterministic) {
  SequenceOptions o = DefaultSequenceOptions(SceneKind::kStreetJunction);
  o.world_seed = 1;
  o.num_frames = 160;
  const SyntheticSequence again(o);  // the world built again from scratch
  const StereoFrame a = seq_->Render(150), b = again.Render(150);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace pl_slam::sim
