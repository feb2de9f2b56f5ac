// Stereo point disparities against dense ground truth (KITTI 2015 000046, real images).
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pl_slam/features/point_features.h"
#include "pl_slam/matching/point_matching.h"

namespace pl_slam {
namespace {

const char kKitti2015[] = "../shared/datasets/stereo_disparity_gt/KITTI_2015/training";

TEST(PointDisparityGroundTruth, Kitti2015PairMatchesTheGroundTruth) {
  if (!std::filesystem::is_directory(kKitti2015)) {
    GTEST_SKIP() << kKitti2015 << " not found; real-data test skipped";
  }
  const std::string base = std::string(kKitti2015);
  const cv::Mat left = cv::imread(base + "/image_2/000046_10.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(base + "/image_3/000046_10.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat gt = cv::imread(base + "/disp_occ_0/000046_10.png", cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(left.empty() || right.empty() || gt.empty());
  ASSERT_EQ(gt.type(), CV_16UC1);
  StereoCamera cam;  // only the disparity matters here; a plausible KITTI model
  cam.fx = cam.fy = 721.5;
  cam.cx = left.cols / 2.0;
  cam.cy = left.rows / 2.0;
  cam.baseline = 0.54;
  cam.width = left.cols;
  cam.height = left.rows;

  for (bool subpixel : {false, true}) {
    PointDetector det{PointDetectorOptions()};
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    det.Detect(left, &kl, &dl);
    det.Detect(right, &kr, &dr);
    PointMatchingOptions mo;
    mo.subpixel = subpixel;
    PointFeatures pts;
    MatchStereoPoints(cam, left, right, kl, dl, kr, dr, mo, &pts);
    std::vector<double> err, abs_err;
    for (const auto& p : pts) {
      if (!p.has_depth) continue;
      const uint16_t g = gt.at<uint16_t>(static_cast<int>(std::lround(p.uv.y())),
                                         static_cast<int>(std::lround(p.uv.x())));
      if (g == 0) continue;  // no ground truth there
      err.push_back(p.disparity - g / 256.0);
      abs_err.push_back(std::abs(err.back()));
    }
    ASSERT_GT(err.size(), 50u);  // the LiDAR ground truth covers the lower part of the image only
    std::sort(err.begin(), err.end());
    std::sort(abs_err.begin(), abs_err.end());
    const double bias = err[err.size() / 2];
    const double within1 =
        static_cast<double>(std::lower_bound(abs_err.begin(), abs_err.end(), 1.0) -
                            abs_err.begin()) /
        abs_err.size();
    std::cout << "subpixel=" << subpixel << ": " << err.size()
              << " matches with ground truth, median signed error " << bias
              << " px, median |error| " << abs_err[abs_err.size() / 2] << " px, within 1 px "
              << 100.0 * within1 << "%, within 3 px "
              << 100.0 * (std::lower_bound(abs_err.begin(), abs_err.end(), 3.0) - abs_err.begin()) /
                     abs_err.size()
              << "%\n";
    // Precision of the matches: no gross mismatch, most within a pixel. The median signed error
    // (-0.53 px here, not seen on the synthetic scenes) is printed, not asserted: its cause is
    // an open question of the tracking issue (it inflates KITTI depths by a few per cent).
    EXPECT_EQ(abs_err.back() < 3.0, true) << "a stereo mismatch of " << abs_err.back() << " px";
    if (subpixel) EXPECT_GT(within1, 0.8);
  }
}

}  // namespace
}  // namespace pl_slam
