// Ray-casting renderer for the synthetic world: exact per-pixel visibility (z-buffer over all
// quads), trilinear mip-mapped texture lookup, and supersampling at occlusion boundaries.
#pragma once

#include <memory>
#include <opencv2/core.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/sim/world.h"

namespace pl_slam::sim {

/// One rendered view of the world, before exposure and noise.
struct RenderedView {
  cv::Mat radiance;  ///< CV_32FC1 grey levels (world texture values, not clamped or noisy)
  cv::Mat depth;     ///< CV_32FC1 depth Z (metres) of the surface at each pixel centre; 0 = none
  cv::Mat quad_id;   ///< CV_32SC1 index of the quad seen at each pixel centre; -1 = none
};

/// Renders pinhole views of a World. Pixel (u, v) is the ray through the camera-frame
/// direction ((u - cx) / fx, (v - cy) / fy, 1), i.e. integer coordinates are pixel centres,
/// which is the convention of StereoCamera::Project. Thread-safe (const) and deterministic:
/// every pixel is computed independently, so the thread count does not change the output.
class Renderer {
 public:
  /// `edge_supersampling` k: pixels on an occlusion or quad boundary average k x k rays
  /// (1 = off); `z_near`: surfaces closer than this (metres) are clipped.
  Renderer(std::shared_ptr<const World> world, const StereoCamera& camera,
           int edge_supersampling = 4, double z_near = 0.05);

  /// Renders the camera whose pose in the world is T_w_c, using the left-camera intrinsics
  /// (the right camera of a rectified pair is the same model at T_w_c * [I | (b, 0, 0)]).
  RenderedView Render(const SE3& T_w_c) const;

  /// The world being rendered.
  const World& world() const { return *world_; }
  /// The camera model (intrinsics and image size).
  const StereoCamera& camera() const { return camera_; }

 private:
  std::shared_ptr<const World> world_;
  StereoCamera camera_;
  int edge_supersampling_;
  double z_near_;
};

}  // namespace pl_slam::sim
