// Bad frames must give a warning and a lost/not-initialised status, never a crash or a NaN pose.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

StereoCamera Camera() { return testing_util::EurocSizedCamera(); }

StereoFrame Frame(const cv::Mat& l, const cv::Mat& r, int i) {
  StereoFrame f;
  f.left = l;
  f.right = r;
  f.index = i;
  f.stamp_ns = 1000000000LL + i * 50000000LL;
  return f;
}

void ExpectFinite(const FrameResult& r) {
  EXPECT_TRUE(r.T_w_c.IsFinite());
  EXPECT_TRUE(r.covariance.allFinite());
}

TEST(SlamSystemBadInput, InvalidConfigurationIsRefused) {
  StereoCamera bad = Camera();
  bad.baseline = -1.0;
  EXPECT_THROW(SlamSystem(bad, SystemOptions()), ConfigError);
  SystemOptions opt;
  opt.tracker.points.max_points = 0;
  try {
    SlamSystem s(Camera(), opt);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_points"), std::string::npos);
  }
  for (const double noise : {-0.5, 11.0, std::nan("")}) {
    SystemOptions o;
    o.tracker.depth_noise = noise;
    try {
      SlamSystem s(Camera(), o);
      ADD_FAILURE() << "depth_noise=" << noise << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("depth_noise"), std::string::npos) << e.what();
    }
  }
  for (const int n : {-1, 1001}) {
    SystemOptions o;
    o.tracker.lost_rotation_min_inliers = n;
    try {
      SlamSystem s(Camera(), o);
      ADD_FAILURE() << "lost_rotation_min_inliers=" << n << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("lost_rotation_min_inliers"), std::string::npos)
          << e.what();
    }
  }
  for (const int levels : {0, 9}) {
    SystemOptions o;
    o.tracker.direct.levels = levels;
    try {
      SlamSystem s(Camera(), o);
      ADD_FAILURE() << "direct.levels=" << levels << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("direct.levels"), std::string::npos) << e.what();
    }
  }
}

TEST(SlamSystemBadInput, EmptyUniformMismatchedAndWrongTypeFrames) {
  SlamSystem sys(Camera(), SystemOptions());
  const cv::Mat gray(480, 752, CV_8UC1, cv::Scalar(128));
  const cv::Mat black(480, 752, CV_8UC1, cv::Scalar(0));
  const cv::Mat small(240, 376, CV_8UC1, cv::Scalar(128));
  const cv::Mat color(480, 752, CV_8UC3, cv::Scalar(1, 2, 3));
  int i = 0;
  for (const auto& [l, r] : std::vector<std::pair<cv::Mat, cv::Mat>>{{cv::Mat(), cv::Mat()},
                                                                     {gray, gray},
                                                                     {black, black},
                                                                     {gray, small},
                                                                     {small, small},
                                                                     {color, color}}) {
    const FrameResult res = sys.Process(Frame(l, r, i++));
    EXPECT_NE(res.state, TrackingState::kTracking);
    EXPECT_FALSE(res.pose_valid);
    ExpectFinite(res);
  }
  EXPECT_TRUE(sys.trajectory().empty());
}

TEST(SlamSystemBadInput, FeaturelessFramesAfterTrackingGiveLostThenRecover) {
  SlamSystem sys(Camera(), SystemOptions());
  cv::Mat textured(480, 752, CV_8UC1);
  cv::RNG rng(5);
  // Blocky random texture: strong, repeatable corners.
  cv::Mat small(60, 94, CV_8UC1);
  rng.fill(small, cv::RNG::UNIFORM, 0, 256);
  cv::resize(small, textured, textured.size(), 0, 0, cv::INTER_NEAREST);
  // The right image of a fronto-parallel plane at 4.95 m: a shift of fx*b/Z = 10 px.
  cv::Mat right = cv::Mat::zeros(textured.size(), CV_8UC1);
  textured(cv::Rect(10, 0, 742, 480)).copyTo(right(cv::Rect(0, 0, 742, 480)));
  FrameResult r0 = sys.Process(Frame(textured, right, 0));
  ASSERT_EQ(r0.state, TrackingState::kTracking);
  FrameResult r1 = sys.Process(Frame(textured, right, 1));
  EXPECT_EQ(r1.state, TrackingState::kTracking);
  EXPECT_LT(r1.T_w_c.translation().norm(), 0.01);  // static camera stays put
  const cv::Mat gray(480, 752, CV_8UC1, cv::Scalar(90));
  FrameResult lost = sys.Process(Frame(gray, gray, 2));
  EXPECT_EQ(lost.state, TrackingState::kLost);
  ExpectFinite(lost);
  // The pose follows the motion model (here: a camera at rest), flagged, never a jump.
  EXPECT_TRUE(lost.predicted);
  EXPECT_FALSE(lost.pose_valid);
  EXPECT_LT((lost.T_w_c.translation() - r1.T_w_c.translation()).norm(), 0.01);
  FrameResult back = sys.Process(Frame(textured, right, 3));
  EXPECT_EQ(back.state, TrackingState::kTracking);
  ExpectFinite(back);
}

}  // namespace
}  // namespace pl_slam

namespace pl_slam {
namespace {

TEST(SystemOptionTable, EveryKeyRoundTripsAndDefaultsAreValid) {
  SystemOptions options;
  EXPECT_EQ(options.Validate(), "");
  const OptionTable table = MakeOptionTable(&options);
  EXPECT_GT(table.keys().size(), 50u);
  for (const std::string& key : table.keys()) {
    const std::string value = table.Get(key);
    EXPECT_NO_THROW(table.Set(key, value)) << key << "=" << value;
    EXPECT_EQ(table.Get(key), value) << key;
  }
  EXPECT_EQ(options.Validate(), "");
  table.Set("tracker.points.max_points", "3");
  EXPECT_NE(options.Validate().find("tracker.points.max_points"), std::string::npos)
      << options.Validate();
  EXPECT_THROW(table.Set("tracker.mode", "corners"), ConfigError);
}

}  // namespace
}  // namespace pl_slam
