// Patch alignment (pl_slam/matching/patch_alignment.h): a patch taken in one
// image is found again, to a small fraction of a pixel, in a shifted and noisy copy; flat and
// unrelated patches are refused.
#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "pl_slam/matching/patch_alignment.h"

namespace pl_slam {
namespace {

// A smooth random texture (sum of sinusoids) sampled with the image shifted by (sx, sy):
// pixel (x, y) shows the texture at (x - sx, y - sy), plus Gaussian noise.
cv::Mat Texture(double sx, double sy, double noise, uint64_t seed) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  struct Wave {
    double kx, ky, phase, amplitude;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 12; ++i)
    waves.push_back(
        {0.6 * (u(rng) - 0.5), 0.6 * (u(rng) - 0.5), 6.28 * u(rng), 10.0 + 10.0 * u(rng)});
  std::mt19937_64 noise_rng(seed);
  std::normal_distribution<double> n(0.0, std::max(noise, 1e-9));
  cv::Mat image(120, 160, CV_8UC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      double v = 128.0;
      for (const Wave& w : waves)
        v += w.amplitude * std::sin(w.kx * (x - sx) + w.ky * (y - sy) + w.phase);
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(v + n(noise_rng));
    }
  return image;
}

// Without noise the patch lands within 0.05 px of where it moved; with the renderer's noise
// (sigma 2 grey levels in both images) within 0.25 px.
TEST(PatchAlignment, FindsAShiftedPatchToAFractionOfAPixel) {
  for (const double noise : {0.0, 2.0}) {
    const double tolerance = noise > 0.0 ? 0.25 : 0.05;
    const cv::Mat reference = Texture(0.0, 0.0, noise, 1);
    const std::vector<std::pair<double, double>> shifts = {{0.37, -0.61}, {-1.2, 0.8}, {0.05, 1.9}};
    for (const auto& [sx, sy] : shifts) {
      const cv::Mat moved = Texture(sx, sy, noise, 2);
      for (const Eigen::Vector2d uv : {Eigen::Vector2d(60.0, 50.0), Eigen::Vector2d(100.3, 70.6)}) {
        const std::vector<uint8_t> patch = TakePatch(reference, uv);
        ASSERT_EQ(patch.size(), static_cast<size_t>(kStoredPatch * kStoredPatch));
        // Start at the detection-like rounded position; the patch is found at uv + shift.
        const Eigen::Vector2d start(std::round(uv.x() + sx), std::round(uv.y() + sy));
        Eigen::Vector2d offset;
        ASSERT_TRUE(AlignPatch(patch, moved, start, 2.5, &offset)) << sx << ", " << sy;
        EXPECT_NEAR(start.x() + offset.x(), uv.x() + sx, tolerance) << sx << ", " << sy;
        EXPECT_NEAR(start.y() + offset.y(), uv.y() + sy, tolerance) << sx << ", " << sy;
      }
    }
  }
}

TEST(PatchAlignment, RefusesFlatUnrelatedAndOutOfImagePatches) {
  const cv::Mat textured = Texture(0.0, 0.0, 2.0, 1);
  const std::vector<uint8_t> patch = TakePatch(textured, Eigen::Vector2d(60.0, 50.0));
  Eigen::Vector2d offset(9.0, 9.0);
  // A flat patch fixes no direction.
  const cv::Mat flat(120, 160, CV_8UC1, cv::Scalar(100));
  EXPECT_FALSE(AlignPatch(TakePatch(flat, Eigen::Vector2d(60.0, 50.0)), textured,
                          Eigen::Vector2d(60.0, 50.0), 2.5, &offset));
  // Another part of the texture does not look like the patch.
  EXPECT_FALSE(AlignPatch(patch, textured, Eigen::Vector2d(120.0, 30.0), 2.5, &offset));
  // Near the border there is nothing to take or align.
  EXPECT_TRUE(TakePatch(textured, Eigen::Vector2d(3.0, 50.0)).empty());
  EXPECT_FALSE(AlignPatch(patch, textured, Eigen::Vector2d(3.0, 50.0), 2.5, &offset));
  // Wrong inputs.
  EXPECT_FALSE(AlignPatch({}, textured, Eigen::Vector2d(60.0, 50.0), 2.5, &offset));
  EXPECT_FALSE(AlignPatch(patch, cv::Mat(), Eigen::Vector2d(60.0, 50.0), 2.5, &offset));
  EXPECT_EQ(offset, Eigen::Vector2d(9.0, 9.0));
}

}  // namespace
}  // namespace pl_slam
