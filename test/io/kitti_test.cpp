// KITTI odometry reading (real clip and synthetic fixtures), dataset folder detection, and
// bad-input errors.
#include "test_util/datasets.h"
#include "test_util/temp_dir.h"
#include "pl_slam/io/kitti.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "pl_slam/io/text_util.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;
using testing_util::DatasetsDir;
using testing_util::WriteText;

// Each test's files go in its own folder, named after this file.
class TempDir : public testing_util::TempDir {
 public:
  TempDir() : testing_util::TempDir("kitti_test") {}
};

template <typename Fn>
void ExpectInputError(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << "message is not one line: " << what;
    for (const auto& p : parts) {
      EXPECT_NE(what.find(p), std::string::npos) << "'" << p << "' not in: " << what;
    }
  }
}

const char* kCalib =
    "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+01 0.000000000000e+00 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+01 0.000000000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
    "P1: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+01 -3.861448000000e+02 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+01 0.000000000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
    "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n";

// A 4-frame 120x40 KITTI sequence with times and poses.
class KittiFixtureTest : public ::testing::Test {
 protected:
  void SetUp() override {
    seq_ = dir_.path() / "00";
    fs::create_directories(seq_ / "image_0");
    fs::create_directories(seq_ / "image_1");
    WriteText(seq_ / "calib.txt", kCalib);
    cv::RNG rng(5);
    std::string times, poses;
    for (int i = 0; i < 4; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.png", i);
      cv::Mat l(40, 120, CV_8UC1), r(40, 120, CV_8UC1);
      rng.fill(l, cv::RNG::UNIFORM, 0, 256);
      rng.fill(r, cv::RNG::UNIFORM, 0, 256);
      cv::imwrite((seq_ / "image_0" / name).string(), l);
      cv::imwrite((seq_ / "image_1" / name).string(), r);
      left_.push_back(l);
      times += text::FormatDouble(0.103 * i) + "\n";
      poses += "1 0 0 " + std::to_string(0.5 * i) + " 0 1 0 0 0 0 1 " + std::to_string(i) + "\n";
    }
    WriteText(seq_ / "times.txt", times);
    WriteText(seq_ / "poses.txt", poses);
  }

  TempDir dir_;
  fs::path seq_;
  std::vector<cv::Mat> left_;
};

TEST_F(KittiFixtureTest, ReadsCameraFramesTimesAndPoses) {
  KittiSource src(seq_.string());
  const StereoCamera& cam = src.camera();
  EXPECT_DOUBLE_EQ(cam.fx, 718.856);
  EXPECT_DOUBLE_EQ(cam.fy, 718.856);
  EXPECT_DOUBLE_EQ(cam.cx, 60.71928);
  EXPECT_DOUBLE_EQ(cam.cy, 18.52157);
  EXPECT_NEAR(cam.baseline, 386.1448 / 718.856, 1e-12);
  EXPECT_EQ(cam.width, 120);
  EXPECT_EQ(cam.height, 40);
  ASSERT_EQ(src.size(), 4u);
  StereoFrame f;
  int i = 0;
  while (src.Next(&f)) {
    EXPECT_EQ(f.index, i);
    EXPECT_EQ(f.stamp_ns, std::llround(0.103 * i * 1e9));
    EXPECT_EQ(cv::norm(f.left, left_[i], cv::NORM_INF), 0.0);
    EXPECT_EQ(f.right.size(), cv::Size(120, 40));
    ++i;
  }
  EXPECT_EQ(i, 4);
  src.Rewind();
  EXPECT_TRUE(src.Next(&f));
  EXPECT_EQ(f.index, 0);
  ASSERT_EQ(src.ground_truth().size(), 4u);
  EXPECT_NEAR(src.ground_truth()[2].t, 0.206, 1e-12);
  EXPECT_NEAR(src.ground_truth()[3].T_w_c.translation().x(), 1.5, 1e-12);
  EXPECT_NEAR(src.ground_truth()[3].T_w_c.translation().z(), 3.0, 1e-12);

  auto opened = OpenDatasetFolder(seq_.string());
  EXPECT_EQ(opened->size(), 4u);
  EXPECT_EQ(opened->Describe().rfind("KITTI", 0), 0u) << opened->Describe();
}

TEST_F(KittiFixtureTest, WithoutTimesUsesTenHertzAndWithoutPosesNoGroundTruth) {
  fs::remove(seq_ / "times.txt");
  fs::remove(seq_ / "poses.txt");
  KittiSource src(seq_.string());
  EXPECT_TRUE(src.ground_truth().empty());
  StereoFrame f;
  src.Read(3, &f);
  EXPECT_EQ(f.stamp_ns, 300000000);
}

TEST_F(KittiFixtureTest, UnpairedImagesAreSkipped) {
  fs::remove(seq_ / "image_1" / "000002.png");
  KittiSource src(seq_.string());
  EXPECT_EQ(src.size(), 3u);
  EXPECT_EQ(src.unpaired_count(), 1u);
  StereoFrame f;
  src.Read(2, &f);
  EXPECT_EQ(cv::norm(f.left, left_[3], cv::NORM_INF), 0.0);
  EXPECT_EQ(f.stamp_ns, std::llround(0.309 * 1e9));
}

TEST_F(KittiFixtureTest, CalibMissingP1) {
  std::string calib = kCalib;
  calib.erase(calib.find("P1:"), calib.find("Tr:") - calib.find("P1:"));
  WriteText(seq_ / "calib.txt", calib);
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"calib.txt", "missing line 'P1:'"});
  ExpectInputError([&] { OpenDatasetFolder(seq_.string()); }, {"calib.txt", "P1"});
}

TEST_F(KittiFixtureTest, CalibShortOrNonNumericP0) {
  WriteText(seq_ / "calib.txt", "P0: 1 2 3\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"calib.txt:1:", "P0", "found 3"});
  WriteText(seq_ / "calib.txt",
            "P0: 700 0 60 0 0 700 20 0 0 0 x 0\nP1: 700 0 60 -380 0 700 20 0 0 0 1 0\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"calib.txt:1:", "'x'"});
  WriteText(seq_ / "calib.txt",
            "P0: 700 0 60 0 0 700 20 0 0 0 1 0\nP1: 700 0 60 380 0 700 20 0 0 0 1 0\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"calib.txt", "baseline"});
}

TEST_F(KittiFixtureTest, TruncatedPosesLine) {
  WriteText(seq_ / "poses.txt",
            "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1\n1 0 0 0 0 1 0 0 0 0\n"
            "1 0 0 0 0 1 0 0 0 0 1 3\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"poses.txt:3:", "12 numbers"});
}

TEST_F(KittiFixtureTest, CountMismatches) {
  WriteText(seq_ / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"poses.txt", "1 poses"});
  WriteText(seq_ / "times.txt", "0\n0.1\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"times.txt", "2 times", "4 images"});
  WriteText(seq_ / "times.txt", "0\n0.1\nabc\n0.3\n");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"times.txt:3:", "'abc'"});
}

TEST_F(KittiFixtureTest, MissingPiecesAndBadImages) {
  ExpectInputError([&] { KittiSource src((dir_.path() / "nope").string()); },
                   {"nope", "no such folder"});
  fs::remove_all(seq_ / "image_1");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"image_1", "missing folder"});
  fs::create_directories(seq_ / "image_1");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"share no file name"});
  for (int i = 0; i < 4; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    cv::imwrite((seq_ / "image_1" / name).string(), cv::Mat::zeros(i == 2 ? 50 : 40, 120, CV_8UC1));
  }
  WriteText(seq_ / "image_0" / "000001.png", "garbage");
  KittiSource src(seq_.string());
  StereoFrame f;
  ExpectInputError([&] { src.Read(1, &f); }, {"image_0/000001.png", "cannot read image"});
  ExpectInputError([&] { src.Read(2, &f); }, {"image_1/000002.png", "120x50", "expected 120x40"});
  fs::remove(seq_ / "calib.txt");
  ExpectInputError([&] { KittiSource src(seq_.string()); }, {"calib.txt", "cannot open"});
}

TEST(DatasetFolderTest, RejectsFoldersOfNeitherLayout) {
  TempDir dir;
  const std::string path = dir.path().string();
  ExpectInputError([&] { OpenDatasetFolder(path); },
                   {path + ": not a dataset folder (expected an EuRoC ASL folder with mav0/ or "
                           "cam0/ and cam1/, or a KITTI odometry folder with calib.txt, "
                           "image_0/, image_1/)"});
  fs::create_directories(dir.path() / "image_0");
  fs::create_directories(dir.path() / "image_1");
  ExpectInputError([&] { OpenDatasetFolder(path); }, {"not a dataset folder"});
  WriteText(dir.path() / "file.bag", "x");
  ExpectInputError([&] { OpenDatasetFolder((dir.path() / "file.bag").string()); },
                   {"file.bag", "not a dataset folder"});
  ExpectInputError([&] { OpenDatasetFolder((dir.path() / "missing").string()); },
                   {"missing", "no such"});
}

TEST(KittiRealDataTest, ReadsClipA) {
  const std::string datasets = DatasetsDir();
  if (datasets.empty()) GTEST_SKIP() << "../shared/datasets not found; real-data test skipped";
  KittiSource src(datasets + "/kitti_clip_a");
  std::cout << "[ info ] " << src.Describe() << "\n";
  const StereoCamera& cam = src.camera();
  EXPECT_DOUBLE_EQ(cam.fx, 718.856);
  EXPECT_DOUBLE_EQ(cam.fy, 718.856);
  EXPECT_DOUBLE_EQ(cam.cx, 607.1928);
  EXPECT_DOUBLE_EQ(cam.cy, 185.2157);
  EXPECT_NEAR(cam.baseline, 0.5371657, 1e-6);
  EXPECT_EQ(cam.width, 1241);
  EXPECT_EQ(cam.height, 376);
  ASSERT_EQ(src.size(), 51u);
  StereoFrame f;
  int n = 0;
  while (src.Next(&f)) {
    ASSERT_EQ(f.left.type(), CV_8UC1);
    ASSERT_EQ(f.right.size(), cv::Size(1241, 376));
    EXPECT_EQ(f.stamp_ns, 100000000LL * n);
    ++n;
  }
  EXPECT_EQ(n, 51);
  const Trajectory& gt = src.ground_truth();
  ASSERT_EQ(gt.size(), 51u);
  EXPECT_NEAR(gt.back().t, 5.0, 1e-9);
  EXPECT_LE((gt.front().T_w_c.matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 1e-6);
  // ~44 m of driving.
  double length = 0.0;
  for (std::size_t i = 1; i < gt.size(); ++i) {
    length += (gt[i].T_w_c.translation() - gt[i - 1].T_w_c.translation()).norm();
  }
  EXPECT_GT(length, 35.0);
  EXPECT_LT(length, 55.0);

  auto opened = OpenDatasetFolder(datasets + "/kitti_clip_a");
  EXPECT_EQ(opened->size(), 51u);
}

}  // namespace
}  // namespace pl_slam
