// Point observations placed by patch alignment instead of where the detector put them.
// A corner detector does not find the same surface point from every view (the measured
// corner moves with scale, blur and the view of the texture around it), so the observations
// of one landmark disagree by a fraction of a pixel in a way noise does not: bundle adjustment
// then pulls the poses with them (see docs/BENCHMARKS.md, pl_slam_bench_ba). Each landmark
// keeps a small patch of its reference keyframe's image around its observation there; every
// other observation is moved to where that patch aligns (translation only, zero-mean
// intensities scaled to the same contrast, inverse compositional Gauss-Newton), so all of
// them refer to one surface point. Views that would warp the patch are left alone.
// Internal to src/mapping.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pl_slam {
namespace mapping {

/// Side of the aligned patch and of the stored one (which has a one-pixel border for the
/// template's gradients).
constexpr int kAlignPatch = 11;
constexpr int kStoredPatch = kAlignPatch + 2;

/// The stored patch around `uv` (bilinear samples, rounded): kStoredPatch^2 values, row-major;
/// empty when it does not fit in the image.
std::vector<uint8_t> TakePatch(const cv::Mat& image, const Eigen::Vector2d& uv);

/// Aligns `patch` (from TakePatch) to `image` starting at `uv`: the offset to add to uv, in
/// `offset`. False (offset untouched) when the patch is too flat to fix both directions, the
/// iteration does not converge, the offset exceeds `max_offset` pixels, or the aligned
/// patches correlate (ZNCC) under 0.8.
bool AlignPatch(const std::vector<uint8_t>& patch, const cv::Mat& image, const Eigen::Vector2d& uv,
                double max_offset, Eigen::Vector2d* offset);

}  // namespace mapping
}  // namespace pl_slam
