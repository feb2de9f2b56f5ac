#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pl_slam/features/point_features.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

TEST(PointDetector, KeypointsAreSpreadOverTheGrid) {
  // Texture only in the left third: without bucketing, a strong cluster would take all.
  cv::Mat img(480, 752, CV_8UC1, cv::Scalar(100));
  cv::RNG rng(1);
  // A dense texture (8 px blocks: thousands of strong corners, like a poster or a carpet).
  // Per-pixel noise would exceed any candidate pool (oversample x max_points), see the header.
  cv::Mat blocks(60, 32, CV_8UC1), noise;
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::resize(blocks, noise, cv::Size(256, 480), 0, 0, cv::INTER_NEAREST);
  noise(cv::Rect(0, 0, 250, 480)).copyTo(img(cv::Rect(0, 0, 250, 480)));
  // Weak blobs everywhere else, one per cell.
  for (int y = 40; y < 480; y += 80)
    for (int x = 300; x < 752; x += 94)
      cv::rectangle(img, cv::Rect(x, y, 12, 12), cv::Scalar(160), cv::FILLED);
  PointDetectorOptions opt;
  opt.max_points = 300;
  PointDetector det(opt);
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  det.Detect(img, &kp, &desc);
  ASSERT_GT(kp.size(), 100u);
  EXPECT_LE(kp.size(), 300u);
  EXPECT_EQ(desc.rows, static_cast<int>(kp.size()));
  int right_part = 0;
  for (const auto& k : kp) right_part += k.pt.x > 300;
  EXPECT_GT(right_part, 20) << "bucketing should keep the weak corners of the plain part";
}

TEST(PointDetector, BucketKeepsQuotaPerCellAndBudget) {
  std::vector<cv::KeyPoint> kps;
  for (int i = 0; i < 200; ++i)
    kps.emplace_back(cv::Point2f(10.f + i * 0.1f, 10.f), 7.f, -1.f, 100.f + i);  // cell 0
  kps.emplace_back(cv::Point2f(90.f, 90.f), 7.f, -1.f, 1.f);                     // cell 3, weak
  const auto kept = BucketKeypoints(kps, cv::Size(100, 100), 2, 2, 40);
  EXPECT_EQ(kept.size(), 40u);
  EXPECT_TRUE(std::any_of(kept.begin(), kept.end(),
                          [](const cv::KeyPoint& k) { return k.response == 1.f; }));
}

TEST(PointDetector, EmptyAndUniformImagesGiveNothing) {
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  det.Detect(cv::Mat(), &kp, &desc);
  EXPECT_TRUE(kp.empty());
  det.Detect(cv::Mat(480, 752, CV_8UC1, cv::Scalar(77)), &kp, &desc);
  EXPECT_TRUE(kp.empty());
  EXPECT_TRUE(desc.empty());
}

TEST(PointDetector, OptionsValidationNamesTheKey) {
  PointDetectorOptions opt;
  opt.grid_cols = 0;
  try {
    PointDetector d(opt);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("grid_cols"), std::string::npos);
  }
}

}  // namespace
}  // namespace pl_slam
