// Texture lookups: texel-centre convention, and pyramid levels aligned with the base so that
// switching level of detail with distance does not move features.
#include "pl_slam/sim/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

namespace pl_slam::sim {
namespace {

TEST(TextureTest, TexelCentresAndBilinearInterpolation) {
  cv::Mat img(8, 8, CV_32F, cv::Scalar(10.0f));
  img.at<float>(3, 5) = 110.0f;  // row 3, column 5
  const Texture tex(img);
  // Texel (column 5, row 3) covers [5, 6) x [3, 4): its centre reads its exact value.
  EXPECT_FLOAT_EQ(tex.SampleLevel(0, 5.5, 3.5), 110.0f);
  // Half way to the next texel centre: the average.
  EXPECT_FLOAT_EQ(tex.SampleLevel(0, 6.0, 3.5), 60.0f);
  EXPECT_FLOAT_EQ(tex.SampleLevel(0, 5.5, 4.0), 60.0f);
  // Clamped outside the texture.
  EXPECT_FLOAT_EQ(tex.SampleLevel(0, -50.0, 1e9), 10.0f);
  // Magnification (lod <= 0) reads the base level.
  EXPECT_FLOAT_EQ(tex.Sample(5.5, 3.5, -2.0), 110.0f);
}

TEST(TextureTest, RejectsEmptyOrColourImages) {
  EXPECT_THROW(Texture(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(Texture(cv::Mat(4, 4, CV_8UC3)), std::invalid_argument);
  const Texture from_bytes(cv::Mat(16, 16, CV_8U, cv::Scalar(7)));
  EXPECT_FLOAT_EQ(from_bytes.SampleLevel(0, 3.0, 3.0), 7.0f);
}

// A blob's centroid, measured by sampling each level on a fine grid of base coordinates, must
// stay where it is on the base level.
TEST(TextureTest, PyramidLevelsStayAlignedWithTheBase) {
  const double cx = 100.3, cy = 80.7, sigma = 6.0;
  cv::Mat img(200, 256, CV_32F);
  for (int r = 0; r < img.rows; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      const double dx = c + 0.5 - cx, dy = r + 0.5 - cy;
      img.at<float>(r, c) =
          static_cast<float>(200.0 * std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma)));
    }
  }
  const Texture tex(img);
  ASSERT_GE(tex.num_levels(), 4);
  for (int l = 0; l < 4; ++l) {
    double sw = 0, sx = 0, sy = 0;
    for (double y = cy - 40; y <= cy + 40; y += 0.5) {
      for (double x = cx - 40; x <= cx + 40; x += 0.5) {
        const double w = tex.SampleLevel(l, x, y);
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    }
    EXPECT_NEAR(sx / sw, cx, 0.15) << "level " << l;
    EXPECT_NEAR(sy / sw, cy, 0.15) << "level " << l;
  }
}

// Anisotropic lookups average along the long axis of the footprint only: a thin line across
// that axis is blurred, one along it survives.
TEST(TextureTest, FootprintFiltersAlongItsLongAxisOnly) {
  cv::Mat img(256, 256, CV_32F, cv::Scalar(0.0f));
  img.rowRange(128, 130).setTo(255.0f);  // a horizontal line, 2 texels thick
  const Texture tex(img);
  // Footprint 4 texels along x (along the line), 1 across: the line stays at full contrast.
  EXPECT_GT(tex.SampleFootprint(100.0, 129.0, 4.0, 0.0, 0.0, 1.0), 250.0f);
  // An isotropic lookup of the same footprint would have blurred it.
  EXPECT_LT(tex.Sample(100.0, 129.0, 2.0), 200.0f);
  // Same footprint turned across the line: it is averaged down.
  EXPECT_LT(tex.SampleFootprint(100.0, 129.0, 0.0, 4.0, 1.0, 0.0), 150.0f);
}

}  // namespace
}  // namespace pl_slam::sim
