// Ground-truth 2D line segments of a rendered frame: the world's structural edges
// (World::StructuralEdges) projected into a camera and cut to their visible parts, for
// measuring a line detector's recall against what is really there.
#pragma once

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <opencv2/core.hpp>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/sim/world.h"

namespace pl_slam::sim {

/// One visible piece of a structural edge in an image.
struct VisibleEdge {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  int edge = -1;                                  ///< index into World::StructuralEdges()
  Eigen::Vector2d a = Eigen::Vector2d::Zero();    ///< first endpoint, pixels
  Eigen::Vector2d b = Eigen::Vector2d::Zero();    ///< second endpoint, pixels
  Eigen::Vector3d a_w = Eigen::Vector3d::Zero();  ///< 3D point seen at a, world
  Eigen::Vector3d b_w = Eigen::Vector3d::Zero();  ///< 3D point seen at b, world
  /// Image length in pixels.
  double length() const { return (b - a).norm(); }
};

/// Options of ProjectStructuralEdges.
struct EdgeVisibilityOptions {
  double step_px = 2.0;         ///< spacing of the visibility samples along an edge, pixels
  double min_length_px = 15.0;  ///< shorter visible pieces are dropped, pixels
  double border_px = 2.0;       ///< samples closer than this to the image border are unseen
  double depth_abs_m = 0.03;    ///< depth-test tolerance: abs + rel * depth, metres
  double depth_rel = 0.02;      ///< relative part of the depth-test tolerance
  double z_near = 0.05;         ///< edges are clipped to depth >= z_near, metres
};

/// The visible parts of the world's structural edges in the camera at T_w_c. `depth` is the
/// renderer's depth image of that view (RenderedView::depth, CV_32FC1, 0 = nothing; same
/// size as the camera). Each edge is clipped to the near plane, sampled every step_px
/// pixels (samples evenly spaced in 3D, so perspective is exact), and a sample counts as
/// visible when it is inside the image and some pixel of the 3 x 3 neighbourhood of its
/// projection has a rendered depth within depth_abs_m + depth_rel * z of the sample's depth z
/// (the neighbourhood admits silhouette edges, whose own pixel may see the surface behind).
/// Runs of consecutive visible samples become VisibleEdges; an edge hidden in its middle
/// gives two. Throws std::invalid_argument when depth is not CV_32FC1 of the camera's size.
std::vector<VisibleEdge, Eigen::aligned_allocator<VisibleEdge>> ProjectStructuralEdges(
    const World& world, const StereoCamera& camera, const SE3& T_w_c, const cv::Mat& depth,
    const EdgeVisibilityOptions& options = EdgeVisibilityOptions());

}  // namespace pl_slam::sim
