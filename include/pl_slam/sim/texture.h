// Grey-level textures for the synthetic world, with a mip pyramid so that surfaces seen far
// away or at grazing angles are prefiltered instead of aliasing (aliasing makes corners and
// edges flicker from frame to frame, which a tracker would see as unstable features).
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

namespace pl_slam::sim {

/// An immutable grey-level texture (intensities in grey levels, 0..255 nominal) and its mip
/// pyramid. Texture coordinates are continuous base-texel coordinates: texel (i, j) of the
/// base level (column i, row j) covers [i, i + 1) x [j, j + 1), so its centre is at
/// (i + 0.5, j + 0.5).
class Texture {
 public:
  /// Takes a CV_8UC1 or CV_32FC1 image (copied as float) and builds the pyramid with
  /// cv::pyrDown, whose Gaussian prefilter is what keeps minified textures alias-free.
  /// Throws std::invalid_argument on an empty or multi-channel image.
  explicit Texture(const cv::Mat& base);

  /// Base-level width in texels.
  int width() const { return levels_[0].cols; }
  /// Base-level height in texels.
  int height() const { return levels_[0].rows; }
  /// Number of pyramid levels (>= 1).
  int num_levels() const { return static_cast<int>(levels_.size()); }
  /// Pyramid level l (0 = base), CV_32FC1.
  const cv::Mat& level(int l) const { return levels_[l]; }

  /// Bilinear sample of level l at base-texel coordinates (x, y), clamped at the borders.
  float SampleLevel(int l, double x, double y) const;
  /// Trilinear sample: lod is log2 of the pixel footprint in base texels (0 or less = base
  /// level, magnified bilinearly); levels are blended linearly in between.
  float Sample(double x, double y, double lod) const;
  /// Anisotropic sample of the pixel footprint whose axes in base texels are (dxu, dyu) (one
  /// pixel step along the image u axis) and (dxv, dyv) (along v): up to kMaxAnisotropy
  /// trilinear taps spread along the longer axis, each at the level of detail of the longer
  /// axis divided by the number of taps (about the shorter axis). Keeps
  /// lines on floors, ceilings and walls seen at grazing angles sharp across them instead of
  /// blurring them away as an isotropic lookup would.
  float SampleFootprint(double x, double y, double dxu, double dyu, double dxv, double dyv) const;

  /// Most taps SampleFootprint takes along the footprint's long axis.
  static constexpr int kMaxAnisotropy = 4;

 private:
  // Raw view of one level for the per-pixel lookups (no cv::Mat indirection there).
  struct LevelView {
    const float* data = nullptr;
    std::size_t stride = 0;  // floats per row
    int max_x = 0, max_y = 0;
    float inv_scale = 1.0f;  // 2^-l
  };

  std::vector<cv::Mat> levels_;
  std::vector<LevelView> views_;
};

}  // namespace pl_slam::sim
