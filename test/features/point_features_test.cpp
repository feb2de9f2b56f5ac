#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

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

// Faint corners (contrast 12 grey levels: below fast_threshold 20, above min_fast_threshold 7)
// are taken where a grid cell has no strong corner, and left out where one has: a poor image
// gains its low-contrast structure without diluting its real corners.
TEST(PointDetector, LowContrastCornersFillOnlyTheEmptyCells) {
  cv::Mat img(480, 752, CV_8UC1, cv::Scalar(100));
  const cv::Rect strong(20, 15, 30, 30), faint_shared(60, 45, 20, 20),
      faint_alone(410, 270, 20, 20);
  cv::rectangle(img, strong, cv::Scalar(200), cv::FILLED);        // cell (0, 0)
  cv::rectangle(img, faint_shared, cv::Scalar(112), cv::FILLED);  // cell (0, 0) too
  cv::rectangle(img, faint_alone, cv::Scalar(112), cv::FILLED);   // cell (4, 3), alone
  auto near = [](const std::vector<cv::KeyPoint>& kp, const cv::Rect& r) {
    return std::count_if(kp.begin(), kp.end(), [&](const cv::KeyPoint& k) {
      return k.pt.x > r.x - 6 && k.pt.x < r.x + r.width + 6 && k.pt.y > r.y - 6 &&
             k.pt.y < r.y + r.height + 6;
    });
  };
  PointDetectorOptions opt;
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  PointDetector(opt).Detect(img, &kp, &desc);
  EXPECT_GT(near(kp, strong), 0);
  EXPECT_GT(near(kp, faint_alone), 0) << "a cell without strong corners takes faint ones";
  EXPECT_EQ(near(kp, faint_shared), 0) << "a cell with strong corners keeps only those";
  opt.min_fast_threshold = opt.fast_threshold;  // the low-contrast search off
  PointDetector(opt).Detect(img, &kp, &desc);
  EXPECT_GT(near(kp, strong), 0);
  EXPECT_EQ(near(kp, faint_alone), 0);
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

// Bad input gets a clear error or nothing, never a crash: a colour image is refused by name, an
// image too small for the pyramid (levels under a pixel) gives what its levels hold.
TEST(PointDetector, OddImagesAreRefusedOrGiveNothing) {
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  try {
    det.Detect(cv::Mat(480, 752, CV_8UC3, cv::Scalar(10, 20, 30)), &kp, &desc);
    FAIL() << "a colour image was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CV_8UC1"), std::string::npos) << e.what();
  }
  PointDetectorOptions deep;
  deep.levels = 12;
  deep.scale_factor = 2.0;
  cv::Mat small(24, 40, CV_8UC1);
  cv::RNG(5).fill(small, cv::RNG::UNIFORM, 0, 256);
  EXPECT_NO_THROW(PointDetector(deep).Detect(small, &kp, &desc));
  EXPECT_TRUE(kp.empty());  // every pixel lies within ORB's 19 px border
  cv::Mat tiny(1, 1, CV_8UC1, cv::Scalar(3));
  EXPECT_NO_THROW(PointDetector(deep).Detect(tiny, &kp, &desc));
  EXPECT_TRUE(kp.empty());
}

// Builds OpenCV ORB's pyramid the way ORB does (each level resized from the one before to the
// rounded size) and finds a blurred blob in each level: its level position mapped back must
// land where the blob is in the full image. Scaling by s^level alone (what ORB reports) is off
// by 0.1-0.7 px, so this fails without the half-pixel and rounding terms.
TEST(PointDetector, PyramidLevelPositionsMapBackToTheImage) {
  const cv::Size size(752, 480);
  const float sf = 1.2f;
  double worst_naive = 0.0;
  for (const cv::Point2d blob :
       {cv::Point2d(100.3, 110.2), cv::Point2d(400.0, 260.0), cv::Point2d(700.7, 410.4)}) {
    cv::Mat img(size, CV_32F);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        const double d2 = (x - blob.x) * (x - blob.x) + (y - blob.y) * (y - blob.y);
        img.at<float>(y, x) = static_cast<float>(std::exp(-d2 / (2.0 * 6.0 * 6.0)));
      }
    cv::Mat level_img = img;
    for (int level = 1; level < 4; ++level) {
      const float s = static_cast<float>(std::pow(static_cast<double>(sf), level));
      cv::Mat next;
      cv::resize(level_img, next, cv::Size(cvRound(size.width / s), cvRound(size.height / s)), 0, 0,
                 cv::INTER_LINEAR);
      level_img = next;
      double sx = 0.0, sy = 0.0, sw = 0.0;
      for (int y = 0; y < level_img.rows; ++y)
        for (int x = 0; x < level_img.cols; ++x) {
          const double w = level_img.at<float>(y, x) > 0.05f ? level_img.at<float>(y, x) : 0.0;
          sx += w * x;
          sy += w * y;
          sw += w;
        }
      const cv::Point2f in_level(static_cast<float>(sx / sw), static_cast<float>(sy / sw));
      const cv::Point2f mapped = PyramidLevelToImage(in_level, level, size, sf);
      EXPECT_NEAR(mapped.x, blob.x, 0.05) << "level " << level;
      EXPECT_NEAR(mapped.y, blob.y, 0.05) << "level " << level;
      const cv::Point2f naive = in_level * s;
      worst_naive = std::max({worst_naive, std::abs(naive.x - blob.x), std::abs(naive.y - blob.y)});
    }
  }
  EXPECT_GT(worst_naive, 0.3);  // the error the mapping removes
  EXPECT_EQ(PyramidLevelToImage(cv::Point2f(12.25f, 7.5f), 0, size, sf), cv::Point2f(12.25f, 7.5f));
}

// FAST finds corners on whole pixels of a pyramid level, so every keypoint the detector reports
// must map back (level by level, inverting cv::resize's centre alignment) onto whole pixels.
TEST(PointDetector, ReportsUpperLevelKeypointsAtTheirImagePositions) {
  cv::Mat blocks(60, 94, CV_8UC1), img;
  cv::RNG rng(3);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::resize(blocks, img, cv::Size(752, 480), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  PointDetectorOptions opt;
  PointDetector det(opt);
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  det.Detect(img, &kp, &desc);
  const float sf = static_cast<float>(opt.scale_factor);
  auto level_size = [&](int l) {
    const float s = static_cast<float>(std::pow(static_cast<double>(sf), l));
    return cv::Size2d(cvRound(img.cols / s), cvRound(img.rows / s));
  };
  int upper = 0;
  for (const cv::KeyPoint& k : kp) {
    if (k.octave <= 0) continue;
    ++upper;
    double x = k.pt.x, y = k.pt.y;
    for (int l = 1; l <= k.octave; ++l) {
      x = (x + 0.5) * level_size(l).width / level_size(l - 1).width - 0.5;
      y = (y + 0.5) * level_size(l).height / level_size(l - 1).height - 0.5;
    }
    EXPECT_NEAR(x, std::round(x), 2e-3) << "octave " << k.octave << " at " << k.pt;
    EXPECT_NEAR(y, std::round(y), 2e-3) << "octave " << k.octave << " at " << k.pt;
  }
  EXPECT_GT(upper, 50);
}

// The detector computes ORB's candidate ranking itself so that it measures orientations only
// for the keypoints bucketing keeps; what it returns must be what OpenCV's ORB gives: its
// detection, bucketed, then its descriptors. A wrong pyramid, border, Harris score, level share
// or orientation changes the kept set, an angle or a descriptor bit (the vocabulary was trained
// on OpenCV's). Checked on a textured image and on a poor one (the low-threshold second search).
TEST(PointDetector, KeepsWhatOpenCvOrbKeeps) {
  cv::RNG rng(11);
  cv::Mat blocks(48, 94, CV_8UC1), textured;
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::resize(blocks, textured, cv::Size(752, 480), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(textured, textured, cv::Size(3, 3), 0.8);
  cv::Mat poor(480, 752, CV_8UC1, cv::Scalar(120));
  for (int i = 0; i < 12; ++i) {
    const cv::Rect r(rng.uniform(30, 680), rng.uniform(30, 420), rng.uniform(15, 50),
                     rng.uniform(15, 50));
    cv::rectangle(poor, r, cv::Scalar(120 + (i % 2 ? 12 : 40)), cv::FILLED);  // faint and strong
  }
  cv::Mat noise(poor.size(), CV_16S);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  poor.convertTo(poor, CV_16S);
  poor += noise;
  poor.convertTo(poor, CV_8U);
  const PointDetectorOptions opt;
  for (const cv::Mat& img : {textured, poor}) {
    const int pool = static_cast<int>(opt.max_points * opt.oversample);
    cv::Ptr<cv::ORB> orb = cv::ORB::create(pool, static_cast<float>(opt.scale_factor), opt.levels,
                                           19, 0, 2, cv::ORB::HARRIS_SCORE, 31, opt.fast_threshold);
    std::vector<cv::KeyPoint> all;
    orb->detect(img, all);
    const bool second = static_cast<int>(all.size()) < opt.max_points;
    EXPECT_EQ(second, img.data == poor.data) << "the poor image must take the second search";
    if (second) {
      std::vector<char> occupied(opt.grid_cols * opt.grid_rows, 0);
      auto cell = [&](const cv::Point2f& p) {
        return std::min(static_cast<int>(p.y * opt.grid_rows / img.rows), opt.grid_rows - 1) *
                   opt.grid_cols +
               std::min(static_cast<int>(p.x * opt.grid_cols / img.cols), opt.grid_cols - 1);
      };
      for (const cv::KeyPoint& k : all) occupied[cell(k.pt)] = 1;
      std::vector<cv::KeyPoint> weak;
      orb->setFastThreshold(opt.min_fast_threshold);
      orb->detect(img, weak);
      for (const cv::KeyPoint& k : weak)
        if (!occupied[cell(k.pt)]) all.push_back(k);
    }
    std::vector<cv::KeyPoint> expected =
        BucketKeypoints(all, img.size(), opt.grid_cols, opt.grid_rows, opt.max_points);
    cv::Mat expected_desc;
    orb->compute(img, expected, expected_desc);

    std::vector<cv::KeyPoint> kp;
    cv::Mat desc;
    PointDetector(opt).Detect(img, &kp, &desc);
    ASSERT_EQ(kp.size(), expected.size()) << (second ? "poor image" : "textured image");
    ASSERT_GT(kp.size(), 100u);
    // The same set, in whatever order: both sorted by level and position.
    auto by_place = [](const std::vector<cv::KeyPoint>& k) {
      std::vector<int> order(k.size());
      for (std::size_t i = 0; i < k.size(); ++i) order[i] = static_cast<int>(i);
      std::sort(order.begin(), order.end(), [&](int a, int b) {
        return std::make_tuple(k[a].octave, k[a].pt.y, k[a].pt.x) <
               std::make_tuple(k[b].octave, k[b].pt.y, k[b].pt.x);
      });
      return order;
    };
    const std::vector<int> oe = by_place(expected), ok = by_place(kp);
    for (std::size_t n = 0; n < kp.size(); ++n) {
      const int i = ok[n];
      const cv::KeyPoint& e = expected[oe[n]];
      const float s = static_cast<float>(std::pow(opt.scale_factor, e.octave));
      const cv::Point2f at = e.octave > 0
                                 ? PyramidLevelToImage(e.pt / s, e.octave, img.size(),
                                                       static_cast<float>(opt.scale_factor))
                                 : e.pt;
      ASSERT_EQ(kp[i].octave, e.octave) << i;
      ASSERT_NEAR(kp[i].pt.x, at.x, 1e-3) << i;
      ASSERT_NEAR(kp[i].pt.y, at.y, 1e-3) << i;
      ASSERT_FLOAT_EQ(kp[i].angle, e.angle) << i;
      ASSERT_FLOAT_EQ(kp[i].response, e.response) << i;
      ASSERT_EQ(cv::norm(desc.row(i), expected_desc.row(oe[n]), cv::NORM_HAMMING), 0.0) << i;
    }
  }
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
