// pl_slam_convert: dataset folders to bags. A synthetic EuRoC folder runs everywhere; the
// shared EuRoC and KITTI folders (../shared/datasets) run where they exist and skip otherwise.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>

#include "pl_slam/io/euroc.h"
#include "pl_slam/io/kitti.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/ros/camera_info_rectifier.h"
#include "pl_slam/ros/dataset_to_bag.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"
#include "test_util/datasets.h"
#include "test_util/temp_dir.h"

namespace pl_slam {
namespace ros_layer {
namespace {

namespace fs = std::filesystem;

class TempDir : public testing_util::TempDir {
 public:
  TempDir() : testing_util::TempDir("convert_test") {}
};

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size()) return 1e9;
  return cv::norm(a, b, cv::NORM_L1) / static_cast<double>(a.total());
}

// The first camera_info pair of a bag.
void FirstInfos(const std::string& bag_path, sensor_msgs::CameraInfo* left,
                sensor_msgs::CameraInfo* right) {
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  for (int side = 0; side < 2; ++side) {
    rosbag::View view(bag,
                      rosbag::TopicQuery(side == 0 ? "/cam0/camera_info" : "/cam1/camera_info"));
    ASSERT_GT(view.size(), 0u);
    *(side == 0 ? left : right) = *view.begin()->instantiate<sensor_msgs::CameraInfo>();
  }
}

// A small synthetic sequence written as an EuRoC folder, stamps starting at 0.
std::string WriteSyntheticEuroc(const TempDir& dir, sim::SyntheticSequence* seq_out = nullptr) {
  sim::SequenceOptions opt;
  opt.num_frames = 4;
  opt.width = 160;
  opt.height = 120;
  opt.focal = 110.0;
  opt.start_time_s = 0.0;
  sim::SyntheticSequence seq(opt);
  const std::string folder = dir.File("euroc");
  EurocWriter writer(folder, seq.camera(), opt.rate_hz);
  StereoFrame f;
  while (seq.Next(&f)) writer.Add(f);
  writer.Finish(seq.ground_truth());
  return folder;
}

TEST(Convert, SyntheticEurocFolderRoundTripsThroughTheBag) {
  TempDir dir;
  const std::string folder = WriteSyntheticEuroc(dir);
  const std::string bag = dir.File("out/seq.bag");  // parent folder is created
  ConvertOptions opt;
  const ConvertSummary s = ConvertDatasetToBag(folder, bag, opt);
  EXPECT_EQ(s.kind, "EuRoC");
  EXPECT_EQ(s.frames, 4u);
  EXPECT_EQ(s.poses, 4u);
  EXPECT_DOUBLE_EQ(s.time_offset_s, 1000.0);  // stamps started at 0
  EXPECT_FALSE(fs::exists(bag + ".tmp"));

  EurocSource euroc(folder);
  BagStereoSource read(bag);
  ASSERT_EQ(read.size(), 4u);
  EXPECT_DOUBLE_EQ(read.camera().fx, euroc.camera().fx);
  EXPECT_DOUBLE_EQ(read.camera().baseline, euroc.camera().baseline);
  ASSERT_EQ(read.ground_truth().size(), 4u);
  EXPECT_NEAR(read.ground_truth()[1].t - euroc.ground_truth()[1].t, 1000.0, 1e-6);
  StereoFrame a, b;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(euroc.Next(&a));
    ASSERT_TRUE(read.Next(&b));
    EXPECT_EQ(b.stamp_ns - a.stamp_ns, 1000000000000LL);
    EXPECT_EQ(MeanAbsDiff(a.left, b.left), 0.0);
    EXPECT_EQ(MeanAbsDiff(a.right, b.right), 0.0);
  }

  // --raw of an undistorted folder: camera_info still says "nothing to rectify".
  opt.raw = true;
  opt.max_frames = 2;
  opt.time_offset_s = 5.0;
  const ConvertSummary raw = ConvertDatasetToBag(folder, dir.File("raw.bag"), opt);
  EXPECT_EQ(raw.frames, 2u);
  EXPECT_DOUBLE_EQ(raw.time_offset_s, 5.0);
  sensor_msgs::CameraInfo l, r;
  FirstInfos(dir.File("raw.bag"), &l, &r);
  EXPECT_EQ(l.distortion_model, "plumb_bob");
  EXPECT_FALSE(InfoNeedsRectification(l));
  EXPECT_EQ(BagStereoSource(dir.File("raw.bag")).size(), 2u);
}

TEST(Convert, BadInputGivesOneLineErrorsAndNoBag) {
  TempDir dir;
  auto message = [](const std::string& in, const std::string& out, ConvertOptions opt) {
    try {
      ConvertDatasetToBag(in, out, opt);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = dir.File("no_such_folder");
  EXPECT_NE(message(missing, dir.File("a.bag"), {}).find(missing), std::string::npos);
  fs::create_directories(dir.File("empty"));
  EXPECT_NE(message(dir.File("empty"), dir.File("a.bag"), {}).find("not a dataset folder"),
            std::string::npos);
  ConvertOptions neg;
  neg.max_frames = -1;
  EXPECT_NE(message(WriteSyntheticEuroc(dir), dir.File("a.bag"), neg).find("--max-frames"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir.File("a.bag")));
  EXPECT_FALSE(fs::exists(dir.File("a.bag.tmp")));

  // The tool: one line on stderr, exit code 1 (bad input) or 2 (bad usage).
  const std::string err = dir.File("stderr.txt");
  auto run = [&](const std::string& args) {
    const int rc = std::system(
        (std::string(PL_SLAM_CONVERT_BIN) + " " + args + " >/dev/null 2>" + err).c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  auto stderr_lines = [&] {
    std::ifstream in(err);
    std::string line, first;
    int n = 0;
    while (std::getline(in, line)) {
      if (n++ == 0) first = line;
    }
    return std::make_pair(n, first);
  };
  EXPECT_EQ(run(missing + " " + dir.File("b.bag")), 1);
  auto [lines, first] = stderr_lines();
  EXPECT_EQ(lines, 1);
  EXPECT_EQ(first.rfind("pl_slam_convert: error: " + missing, 0), 0u) << first;
  EXPECT_EQ(run(dir.File("euroc") + " " + dir.File("b.bag") + " --max-frames x"), 2);
  EXPECT_EQ(stderr_lines().first, 1);
  EXPECT_FALSE(fs::exists(dir.File("b.bag")));
  EXPECT_EQ(run(dir.File("euroc") + " " + dir.File("c.bag") + " --max-frames 2"), 0);
  EXPECT_TRUE(fs::exists(dir.File("c.bag")));
}

TEST(Convert, SharedEurocFolderRawAndRectified) {
  const std::string root = testing_util::DatasetsDir();
  if (root.empty()) GTEST_SKIP() << "../shared/datasets absent: EuRoC conversion not checked";
  const std::string folder = root + "/euroc_mh01_f100-249";
  TempDir dir;
  ConvertOptions opt;
  opt.max_frames = 3;
  const ConvertSummary rect = ConvertDatasetToBag(folder, dir.File("rect.bag"), opt);
  EXPECT_EQ(rect.frames, 3u);
  EXPECT_DOUBLE_EQ(rect.time_offset_s, 0.0);  // EuRoC stamps are epoch times
  EXPECT_GT(rect.poses, 3u);                  // 200 Hz ground truth around the frames
  opt.raw = true;
  const ConvertSummary raw = ConvertDatasetToBag(folder, dir.File("raw.bag"), opt);
  EXPECT_TRUE(raw.raw);

  sensor_msgs::CameraInfo l, r;
  FirstInfos(dir.File("raw.bag"), &l, &r);
  EXPECT_EQ(l.distortion_model, "plumb_bob");
  EXPECT_NE(l.D[0], 0.0);
  EXPECT_TRUE(InfoNeedsRectification(l));
  EXPECT_TRUE(InfoNeedsRectification(r));
  FirstInfos(dir.File("rect.bag"), &l, &r);
  EXPECT_FALSE(InfoNeedsRectification(l));
  EXPECT_FALSE(InfoNeedsRectification(r));

  // Rectified by the reader from the raw bag's camera_info = rectified by the EuRoC reader.
  EurocSource euroc(folder);
  BagStereoSource from_raw(dir.File("raw.bag")), from_rect(dir.File("rect.bag"));
  EXPECT_NEAR(from_raw.camera().fx, euroc.camera().fx, 1e-9);
  EXPECT_NEAR(from_raw.camera().baseline, euroc.camera().baseline, 1e-9);
  StereoFrame e, a, b;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(euroc.Next(&e));
    ASSERT_TRUE(from_raw.Next(&a));
    ASSERT_TRUE(from_rect.Next(&b));
    EXPECT_EQ(a.stamp_ns, e.stamp_ns);
    EXPECT_EQ(MeanAbsDiff(b.left, e.left), 0.0);
    EXPECT_LT(MeanAbsDiff(a.left, e.left), 0.5);
    EXPECT_LT(MeanAbsDiff(a.right, e.right), 0.5);
  }
}

TEST(Convert, SharedKittiFolder) {
  const std::string root = testing_util::DatasetsDir();
  if (root.empty()) GTEST_SKIP() << "../shared/datasets absent: KITTI conversion not checked";
  const std::string folder = root + "/kitti_clip_a";
  TempDir dir;
  ConvertOptions opt;
  opt.max_frames = 5;
  const ConvertSummary s = ConvertDatasetToBag(folder, dir.File("kitti.bag"), opt);
  EXPECT_EQ(s.kind, "KITTI");
  EXPECT_EQ(s.frames, 5u);
  EXPECT_EQ(s.poses, 5u);
  EXPECT_DOUBLE_EQ(s.time_offset_s, 1000.0);  // KITTI times start at 0
  KittiSource kitti(folder);
  BagStereoSource bag(dir.File("kitti.bag"));
  EXPECT_EQ(bag.camera().width, 1241);
  EXPECT_NEAR(bag.camera().baseline, kitti.camera().baseline, 1e-9);
  StereoFrame a, b;
  ASSERT_TRUE(kitti.Next(&a));
  ASSERT_TRUE(bag.Next(&b));
  EXPECT_EQ(MeanAbsDiff(a.left, b.left), 0.0);

  opt.raw = true;
  try {
    ConvertDatasetToBag(folder, dir.File("raw.bag"), opt);
    ADD_FAILURE() << "--raw accepted for KITTI";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--raw applies to EuRoC"), std::string::npos);
  }
  // Loose image pairs are not a sequence.
  EXPECT_THROW(ConvertDatasetToBag(root + "/euroc_v101_loop_pairs", dir.File("v.bag"), {}),
               InputError);
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
