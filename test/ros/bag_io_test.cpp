// Bag writer/reader round trip and message conversions (no master needed).
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>

#include "test_util/temp_dir.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace ros_layer {
namespace {

namespace fs = std::filesystem;

// Each test's files go in its own folder, named after this file.
class TempDir : public testing_util::TempDir {
 public:
  TempDir() : testing_util::TempDir("bag_test") {}
};

StereoCamera TestCamera() { return testing_util::CenteredCamera(100.0, 0.1, 64, 48); }

cv::Mat RandomImage(int seed) {
  cv::Mat m(48, 64, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

TEST(BagIo, RoundTripKeepsImagesStampsCameraAndGroundTruth) {
  TempDir dir;
  const std::string bag = dir.File("seq.bag");
  Trajectory gt;
  {
    StereoBagWriter writer(bag, TestCamera());
    for (int i = 0; i < 5; ++i) {
      StereoFrame f;
      f.stamp_ns = 1000000000LL + i * 50000000LL;
      f.index = i;
      f.left = RandomImage(2 * i);
      f.right = RandomImage(2 * i + 1);
      writer.Write(f);
      StampedPose p;
      p.t = f.stamp_s();
      p.T_w_c = SE3::Exp((Vector6d() << 0.1 * i, 0.0, 0.2, 0.0, 0.05 * i, 0.0).finished());
      gt.push_back(p);
    }
    EXPECT_FALSE(fs::exists(bag)) << "bag visible before Close()";
    writer.WriteGroundTruth(gt);
    writer.Close();
  }
  ASSERT_TRUE(fs::exists(bag));
  EXPECT_FALSE(fs::exists(bag + ".tmp"));

  BagStereoSource src(bag);
  EXPECT_EQ(src.size(), 5u);
  EXPECT_DOUBLE_EQ(src.camera().fx, 100.0);
  EXPECT_DOUBLE_EQ(src.camera().cx, 31.5);
  EXPECT_NEAR(src.camera().baseline, 0.1, 1e-12);
  ASSERT_EQ(src.ground_truth().size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR(src.ground_truth()[i].t, gt[i].t, 1e-9);
    EXPECT_LT((src.ground_truth()[i].T_w_c.inverse() * gt[i].T_w_c).Log().norm(), 1e-9);
  }
  StereoFrame f;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(src.Next(&f));
    EXPECT_EQ(f.index, i);
    EXPECT_EQ(f.stamp_ns, 1000000000LL + i * 50000000LL);
    EXPECT_EQ(cv::norm(f.left, RandomImage(2 * i), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(f.right, RandomImage(2 * i + 1), cv::NORM_INF), 0.0);
  }
  EXPECT_FALSE(src.Next(&f));
  EXPECT_EQ(src.unpaired(), 0);
}

TEST(BagIo, WriterDestroyedWithoutCloseLeavesNothing) {
  TempDir dir;
  const std::string bag = dir.File("partial.bag");
  {
    StereoBagWriter writer(bag, TestCamera());
    StereoFrame f;
    f.stamp_ns = 1;
    f.left = RandomImage(1);
    f.right = RandomImage(2);
    writer.Write(f);
  }
  EXPECT_FALSE(fs::exists(bag));
  EXPECT_FALSE(fs::exists(bag + ".tmp"));
}

TEST(BagIo, BadBagsGiveInputErrorsNamingTheFile) {
  TempDir dir;
  const std::string missing = dir.File("missing.bag");
  try {
    BagStereoSource s(missing);
    FAIL() << "no error for a missing bag";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.bag"), std::string::npos) << e.what();
  }
  const std::string junk = dir.File("junk.bag");
  std::ofstream(junk) << "this is not a bag\n";
  EXPECT_THROW(BagStereoSource s(junk), InputError);

  // A valid bag without the expected topics.
  const std::string other = dir.File("other.bag");
  {
    BagTopics t;
    t.left_image = "/a/image";
    t.right_image = "/b/image";
    StereoBagWriter w(other, TestCamera(), t);
    StereoFrame f;
    f.stamp_ns = 5;
    f.left = RandomImage(1);
    f.right = RandomImage(2);
    w.Write(f);
    w.Close();
  }
  try {
    BagStereoSource s(other);
    FAIL() << "no error for missing topics";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/cam0/image_raw"), std::string::npos) << e.what();
  }
  // ... but it reads with the right topic names.
  BagTopics t;
  t.left_image = "/a/image";
  t.right_image = "/b/image";
  BagStereoSource ok(other, t);
  EXPECT_EQ(ok.size(), 1u);
}

sensor_msgs::Image MakeImage(const std::string& encoding, int channels, int bytes_per_channel) {
  sensor_msgs::Image m;
  m.width = 4;
  m.height = 3;
  m.encoding = encoding;
  m.step = m.width * channels * bytes_per_channel;
  m.data.assign(m.step * m.height, 0);
  return m;
}

TEST(Conversions, SupportedEncodingsBecomeMono8) {
  auto rgb = MakeImage(sensor_msgs::image_encodings::RGB8, 3, 1);
  rgb.data[0] = 255;  // pure red pixel
  cv::Mat g = ImageToMono8(rgb);
  ASSERT_EQ(g.type(), CV_8UC1);
  EXPECT_NEAR(g.at<uint8_t>(0, 0), 76, 1);  // 0.299 * 255
  auto bgr = MakeImage(sensor_msgs::image_encodings::BGR8, 3, 1);
  bgr.data[0] = 255;                                        // pure blue pixel
  EXPECT_NEAR(ImageToMono8(bgr).at<uint8_t>(0, 0), 29, 1);  // 0.114 * 255
  auto m16 = MakeImage(sensor_msgs::image_encodings::MONO16, 1, 2);
  m16.data[0] = 0x00;
  m16.data[1] = 0x80;  // little endian 0x8000
  EXPECT_EQ(ImageToMono8(m16).at<uint8_t>(0, 0), 128);
  auto mono = MakeImage(sensor_msgs::image_encodings::MONO8, 1, 1);
  mono.data[5] = 42;
  EXPECT_EQ(ImageToMono8(mono).at<uint8_t>(1, 1), 42);
}

TEST(Conversions, BadImagesAreRejectedWithAMessage) {
  auto f32 = MakeImage(sensor_msgs::image_encodings::TYPE_32FC1, 1, 4);
  try {
    ImageToMono8(f32);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("32FC1"), std::string::npos) << e.what();
  }
  auto truncated = MakeImage(sensor_msgs::image_encodings::MONO8, 1, 1);
  truncated.data.resize(5);
  EXPECT_THROW(ImageToMono8(truncated), InputError);
  auto empty = MakeImage(sensor_msgs::image_encodings::MONO8, 1, 1);
  empty.width = 0;
  EXPECT_THROW(ImageToMono8(empty), InputError);
}

TEST(Conversions, CameraInfoRoundTripAndValidation) {
  sensor_msgs::CameraInfo l, r;
  StereoCameraToInfo(TestCamera(), "cam0", "cam1", &l, &r);
  const StereoCamera c = StereoCameraFromInfo(l, r);
  EXPECT_DOUBLE_EQ(c.fx, 100.0);
  EXPECT_DOUBLE_EQ(c.cy, 23.5);
  EXPECT_NEAR(c.baseline, 0.1, 1e-12);
  EXPECT_EQ(c.width, 64);

  sensor_msgs::CameraInfo uncalibrated = l;
  uncalibrated.P.fill(0.0);
  EXPECT_THROW(StereoCameraFromInfo(uncalibrated, r), InputError);
  sensor_msgs::CameraInfo wrong_size = r;
  wrong_size.width = 32;
  EXPECT_THROW(StereoCameraFromInfo(l, wrong_size), InputError);
  sensor_msgs::CameraInfo no_baseline = r;
  no_baseline.P[3] = 0.0;
  EXPECT_THROW(StereoCameraFromInfo(l, no_baseline), InputError);

  // stereoRectify without CALIB_ZERO_DISPARITY: the right cx differs, which is the camera's
  // doffs, and it survives the round trip.
  sensor_msgs::CameraInfo offset = r;
  offset.P[2] += 1.75;
  const StereoCamera with_offset = StereoCameraFromInfo(l, offset);
  EXPECT_DOUBLE_EQ(with_offset.doffs, 1.75);
  sensor_msgs::CameraInfo l2, r2;
  StereoCameraToInfo(with_offset, "cam0", "cam1", &l2, &r2);
  EXPECT_DOUBLE_EQ(StereoCameraFromInfo(l2, r2).doffs, 1.75);
  sensor_msgs::CameraInfo other_row = r;
  other_row.P[6] += 2.0;  // a different cy: not a rectified pair
  EXPECT_THROW(StereoCameraFromInfo(l, other_row), InputError);
}

TEST(Conversions, PoseMessageRoundTrip) {
  const SE3 T = SE3::Exp((Vector6d() << 1.0, -2.0, 3.0, 0.3, -0.2, 0.1).finished());
  const SE3 back = FromPoseMsg(ToPoseMsg(T));
  EXPECT_LT((back.inverse() * T).Log().norm(), 1e-12);
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
