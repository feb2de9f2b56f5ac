// Direct (photometric) alignment of a frame to a stereo reference frame: tracking's last
// resort when too few features match (StereoTracker::TrackDirect). Edges too faint or too few
// for descriptors still carry the motion in their intensities: the reference's strongest
// gradient pixels get depth from a row search in its right image, and the current left image is
// aligned to them by robust Gauss-Newton over an image pyramid, with an affine brightness
// change, starting at the motion model's prediction (as in direct visual odometry, e.g. DSO,
// Engel et al., PAMI 2018, without its windowed optimisation).
//
// Conventions as in motion_estimator.h: the estimate is T_cur_ref (X_cur = T_cur_ref * X_ref);
// the covariance is for a LEFT perturbation, tangent order [rho; phi].
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

struct DirectAlignmentOptions {
  bool enabled = true;    ///< try the alignment before a frame is reported lost
  int max_pixels = 2000;  ///< reference pixels with depth kept (at most one per grid cell)
  /// Smallest horizontal gradient of a reference pixel, in standard deviations of the
  /// gradient's noise (estimated per image)
  double min_gradient_sigmas = 5.0;
  int levels = 3;             ///< pyramid levels (the coarsest first)
  int min_pixels = 150;       ///< fewer reference pixels in the current image: no estimate
  double max_residual = 8.0;  ///< largest robust residual sigma accepted, grey levels
  /// Largest rotation standard deviation accepted, deg (from the reference gradients with
  /// their noise taken out). Where a view's few edges let rotation and translation trade
  /// off (edges at one depth, or in one direction), the cost has a shallow valley whose
  /// minimum the brightness model's small errors move by degrees; the motion model is the
  /// better guess there.
  double max_rotation_sigma_deg = 0.15;

  /// Empty when valid, else what is wrong (one line).
  std::string Validate() const;
};

/// A reference frame: its left-image pyramid and its pixels with depth.
struct DirectReference {
  std::vector<cv::Mat> pyramid;               ///< CV_32F, level 0 the (smoothed) full image
  std::vector<Eigen::Vector3d> points;        ///< the pixels' 3D points, reference camera frame
  std::vector<std::vector<float>> intensity;  ///< per level, each point's reference intensity
  std::vector<std::vector<Eigen::Vector2f>> gradient;  ///< per level, its intensity gradient
  float gradient_noise = 0.f;  ///< standard deviation of the level-0 gradient's noise, grey/px
  bool empty() const { return points.empty(); }
};

/// Selects the reference pixels (the strongest horizontal gradient per grid cell, above the
/// image's noise), gives them depth by a zero-mean SSD search along the right image's row
/// (unique minima only), and builds the pyramid. Images: CV_8UC1, rectified, the camera's size;
/// disparities searched up to max_disparity (px).
DirectReference BuildDirectReference(const StereoCamera& camera, const cv::Mat& left,
                                     const cv::Mat& right, double max_disparity,
                                     const DirectAlignmentOptions& options);

struct DirectAlignmentResult {
  bool success = false;
  SE3 T_cur_ref;
  Matrix6d covariance = Matrix6d::Zero();  ///< of T_cur_ref (left perturbation)
  int pixels = 0;                          ///< reference pixels inside the current image at the end
  double residual = 0.0;                   ///< robust sigma of the final residuals, grey levels
  std::string failure;                     ///< why not, when !success
};

/// Aligns `cur_left` (CV_8UC1, the camera's size) to `ref` from `prior` (T_cur_ref).
DirectAlignmentResult AlignDirect(const StereoCamera& camera, const DirectReference& ref,
                                  const cv::Mat& cur_left, const SE3& prior,
                                  const DirectAlignmentOptions& options);

}  // namespace pl_slam
