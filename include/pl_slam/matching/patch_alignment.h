// Patch alignment: where a small patch of one image is in another, to a fraction of a pixel.
// A corner detector does not find the same surface point from every view (the measured
// corner moves with its pixel grid, scale, blur and the view of the texture around it), so
// observations of one point disagree by a fraction of a pixel in a way noise does not. A patch
// taken around the point in one view and aligned in another (translation only, zero-mean
// intensities scaled to the same contrast, inverse compositional Gauss-Newton) refers to one
// surface point. Used by local mapping (mapping.align_points: a landmark's observations) and
// frame-to-frame tracking (tracker.point_matching.f2f_align_max_shift); views that would warp
// the patch (PatchWarp) are left alone by both.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

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

/// Largest PatchWarp at which an alignment is trusted: it moves the corners of an 11x11 patch
/// by under 0.6 px.
constexpr double kMaxPatchWarp = 0.08;

/// How much the image around `uv_ref` (depth z_ref in the reference camera) is stretched,
/// sheared or turned in the current view T_cur_ref, the surface taken as facing the reference
/// camera: the largest |singular value - 1| of the local mapping's Jacobian (central
/// differences over 1 px) or its rotation angle, infinity when not computable.
double PatchWarp(const StereoCamera& cam, const SE3& T_cur_ref, const Eigen::Vector2d& uv_ref,
                 double z_ref);

}  // namespace pl_slam
