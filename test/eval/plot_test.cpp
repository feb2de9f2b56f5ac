#include "pl_slam/eval/plot.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "eval_test_util.h"
#include "pl_slam/eval/evaluation.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {
namespace {

namespace fs = std::filesystem;

// Pixels within `tol` of `color` in every channel.
int CountColor(const cv::Mat& img, const cv::Scalar& color, int tol = 12) {
  int n = 0;
  for (int r = 0; r < img.rows; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      const cv::Vec3b& p = img.at<cv::Vec3b>(r, c);
      bool close = true;
      for (int k = 0; k < 3; ++k)
        close = close && std::abs(p[k] - static_cast<int>(color[k])) <= tol;
      n += close;
    }
  }
  return n;
}

struct PlotCase {
  Trajectory gt;
  EvaluationResult result;
};

PlotCase MakeCase() {
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.03);
  PlotCase c;
  c.gt = testing::MakeLoop(200.0, 30.0);
  Trajectory est;
  for (const auto& p : testing::MakeLoop(20.0, 30.0)) {
    StampedPose q = p;
    q.t += 0.0025;
    q.T_w_c.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    est.push_back(q);
  }
  c.result = EvaluateTrajectory(est, c.gt, {});
  return c;
}

fs::path TempDir() {
  const fs::path dir =
      fs::temp_directory_path() / ("pl_slam_plot_test_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  return dir;
}

TEST(Plot, WritesPngOfTheRightSizeWithBothCurves) {
  const PlotCase c = MakeCase();
  const fs::path dir = TempDir();
  const std::string path = (dir / "plot.png").string();
  PlotOptions opt;
  opt.name = "loop_test";
  WriteTrajectoryPlot(path, c.gt, c.result.est_aligned, c.result.ate, opt);
  ASSERT_TRUE(fs::exists(path));
  EXPECT_GT(fs::file_size(path), 10000u);
  const cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 900);
  EXPECT_EQ(img.rows, 700 + opt.error_panel_height);
  // The trajectory panel holds both curves.
  const cv::Mat top = img(cv::Rect(0, 0, 900, 700));
  EXPECT_GT(CountColor(top, kGroundTruthColor), 300);
  EXPECT_GT(CountColor(top, kEstimateColor), 300);
  // The error panel draws the error curve in the estimate colour.
  const cv::Mat bottom = img(cv::Rect(0, 700, 900, opt.error_panel_height));
  EXPECT_GT(CountColor(bottom, kEstimateColor), 100);
  fs::remove_all(dir);
}

TEST(Plot, WithoutErrorPanelAndDegenerateInputs) {
  const PlotCase c = MakeCase();
  PlotOptions opt;
  opt.error_panel_height = 0;
  const cv::Mat img = RenderTrajectoryPlot(c.gt, c.result.est_aligned, c.result.ate, opt);
  EXPECT_EQ(img.size(), cv::Size(900, 700));
  EXPECT_EQ(img.type(), CV_8UC3);

  // A single pose, an empty estimate, all-identical positions: an image, no throw.
  const Trajectory one(c.gt.begin(), c.gt.begin() + 1);
  EXPECT_NO_THROW(RenderTrajectoryPlot(one, one, AteResult{}, PlotOptions{}));
  EXPECT_NO_THROW(RenderTrajectoryPlot(c.gt, {}, AteResult{}, PlotOptions{}));
  Trajectory still = c.gt;
  for (auto& p : still) p.T_w_c.translation().setZero();
  EXPECT_NO_THROW(RenderTrajectoryPlot(still, still, c.result.ate, PlotOptions{}));
  EXPECT_THROW(RenderTrajectoryPlot({}, {}, AteResult{}, PlotOptions{}), InputError);
  opt.width = 10;
  EXPECT_THROW(RenderTrajectoryPlot(c.gt, c.gt, c.result.ate, opt), ConfigError);
  EXPECT_THROW(WriteTrajectoryPlot("/nonexistent_dir_pl_slam/plot.png", c.gt, c.gt, c.result.ate),
               InputError);
}

}  // namespace
}  // namespace eval
}  // namespace pl_slam
