// Procedural, seed-deterministic texture synthesis for the synthetic scenes: smooth noise
// fields, a metric drawing canvas, and the surface styles the built-in scenes use.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pl_slam/sim/texture.h"

namespace pl_slam::sim {

/// Mixes two 64-bit values into a well-scrambled seed (SplitMix64 finaliser), so that
/// per-surface and per-frame random streams are independent yet reproducible.
uint64_t MixSeed(uint64_t a, uint64_t b);

/// A smooth random field of the given size with zero mean and unit standard deviation: a
/// sum of `octaves` bicubically upsampled random grids, the first with cells of
/// `cell_texels` texels, each next one half the cell size and `persistence` times the
/// amplitude (fractional Brownian motion of value noise).
cv::Mat FractalNoise(cv::Size size, double cell_texels, int octaves, double persistence,
                     cv::RNG& rng);

/// A drawing surface in metric units for building a texture: an 8-bit albedo on which shapes
/// are drawn anti-aliased (OpenCV only anti-aliases 8-bit images), then turned into a float
/// Texture with smooth shading and grain added. Coordinates are metres from the texture's
/// (0, 0) corner, x along texture columns, y along rows.
class TextureCanvas {
 public:
  /// A canvas of width_m x height_m metres at texel_m metres per texel, filled with `grey`.
  TextureCanvas(double width_m, double height_m, double texel_m, double grey);

  /// Size in texels.
  cv::Size size() const { return albedo_.size(); }
  /// Width in metres.
  double width_m() const { return width_m_; }
  /// Height in metres.
  double height_m() const { return height_m_; }

  /// Adds amplitude * FractalNoise (cell size in metres) to the albedo, saturating. With
  /// stretch_x > 1 the field is elongated along x (wood grain, brushed paint).
  void AddNoise(double amplitude, double cell_m, int octaves, double persistence, cv::RNG& rng,
                double stretch_x = 1.0);
  /// Filled axis-aligned rectangle [x0, x1] x [y0, y1].
  void FillRect(double x0, double y0, double x1, double y1, double grey);
  /// Filled convex polygon.
  void FillConvex(const std::vector<cv::Point2d>& points, double grey);
  /// Filled ellipse with semi-axes (ax, ay) rotated by angle_deg.
  void FillEllipse(const cv::Point2d& centre, double ax, double ay, double angle_deg, double grey);
  /// Straight stroke of the given thickness.
  void Line(const cv::Point2d& a, const cv::Point2d& b, double thickness_m, double grey);
  /// Rectangle outline of the given stroke thickness.
  void FrameRect(double x0, double y0, double x1, double y1, double thickness_m, double grey);

  /// The texture: albedo * (1 + shading_amplitude * smooth field of cell shading_cell_m) +
  /// Gaussian grain of std grain_sigma per texel.
  std::shared_ptr<const Texture> Finish(double shading_amplitude, double shading_cell_m,
                                        double grain_sigma, cv::RNG& rng) const;

  /// The 8-bit albedo drawn so far (for inspection).
  const cv::Mat& albedo() const { return albedo_; }

 private:
  cv::Point ToFixed(const cv::Point2d& p_m) const;

  cv::Mat albedo_;  // CV_8UC1
  double width_m_;
  double height_m_;
  double texel_m_;
};

/// Surface styles of the textured (feature-rich) scenes.
enum class SurfaceStyle {
  kClutter,     ///< posters, shapes and strokes over mottled paint: many corners at all scales
  kFloorTiles,  ///< square tiles of varying grey with grout lines, some scuffs
  kCeiling,     ///< bright ceiling with light panels and vents, moderately textured
  kWood,        ///< planks with grain and a few labels (boxes, crates)
};

/// A feature-rich texture of the given style covering width_m x height_m, deterministic from
/// `seed`. `base_grey` sets the overall brightness (so adjoining walls differ and their
/// common corner is a visible edge).
std::shared_ptr<const Texture> MakeSurfaceTexture(SurfaceStyle style, double width_m,
                                                  double height_m, double texel_m, double base_grey,
                                                  uint64_t seed);

}  // namespace pl_slam::sim
