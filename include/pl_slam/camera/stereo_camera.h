// The rectified stereo pinhole model every stage works in.
#pragma once

#include <Eigen/Core>
#include <string>

namespace pl_slam {

/// A rectified, horizontally aligned stereo pair: both images share fx, fy, cx, cy; the right
/// camera sits `baseline` metres along the left camera's +x axis. Pixel (u, v) of a point at
/// depth Z in the left image appears at (u - fx * baseline / Z, v) in the right image.
struct StereoCamera {
  double fx = 0.0;        ///< focal length in pixels, x
  double fy = 0.0;        ///< focal length in pixels, y
  double cx = 0.0;        ///< principal point, x (pixels)
  double cy = 0.0;        ///< principal point, y (pixels)
  double baseline = 0.0;  ///< stereo baseline in metres (> 0)
  int width = 0;          ///< image width in pixels
  int height = 0;         ///< image height in pixels

  /// Empty string when usable, else a one-line description of the first bad field.
  std::string Validate() const;

  /// Projects a point in the left camera frame to left-image pixels (z must be > 0).
  Eigen::Vector2d Project(const Eigen::Vector3d& p_c) const {
    return {fx * p_c.x() / p_c.z() + cx, fy * p_c.y() / p_c.z() + cy};
  }
  /// Projects a point in the left camera frame to right-image pixels.
  Eigen::Vector2d ProjectRight(const Eigen::Vector3d& p_c) const {
    return {fx * (p_c.x() - baseline) / p_c.z() + cx, fy * p_c.y() / p_c.z() + cy};
  }
  /// Disparity (pixels) of a point at depth z.
  double DisparityFromDepth(double z) const { return fx * baseline / z; }
  /// Depth (metres) of a disparity d > 0.
  double DepthFromDisparity(double d) const { return fx * baseline / d; }
  /// Back-projects left pixel (u, v) with disparity d > 0 to the left camera frame.
  Eigen::Vector3d BackProject(double u, double v, double d) const {
    const double z = DepthFromDisparity(d);
    return {(u - cx) * z / fx, (v - cy) * z / fy, z};
  }
  /// True when pixel (u, v) lies inside the image.
  bool InImage(const Eigen::Vector2d& uv, double border = 0.0) const {
    return uv.x() >= border && uv.y() >= border && uv.x() < width - border &&
           uv.y() < height - border;
  }
};

}  // namespace pl_slam
