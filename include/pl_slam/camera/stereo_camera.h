// The rectified stereo pinhole model every stage works in.
#pragma once

#include <Eigen/Core>
#include <string>

namespace pl_slam {

/// A rectified, horizontally aligned stereo pair: both images share fx, fy and cy; the right
/// camera sits `baseline` metres along the left camera's +x axis and its principal point is
/// `doffs` pixels right of the left one's (0 for most rectifications; Middlebury's "doffs", the
/// right P's cx minus the left's in ROS). Pixel (u, v) of a point at depth Z in the left image
/// appears at (u - fx * baseline / Z + doffs, v) in the right image, so the measured disparity
/// u_left - u_right is fx * baseline / Z - doffs.
struct StereoCamera {
  double fx = 0.0;        ///< focal length in pixels, x
  double fy = 0.0;        ///< focal length in pixels, y
  double cx = 0.0;        ///< principal point, x (pixels)
  double cy = 0.0;        ///< principal point, y (pixels)
  double baseline = 0.0;  ///< stereo baseline in metres (> 0)
  double doffs = 0.0;     ///< right principal point x minus the left one's (pixels)
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
    return {fx * (p_c.x() - baseline) / p_c.z() + cx + doffs, fy * p_c.y() / p_c.z() + cy};
  }
  /// Measured disparity u_left - u_right (pixels) of a point at depth z.
  double DisparityFromDepth(double z) const { return fx * baseline / z - doffs; }
  /// The geometric disparity fx * baseline / Z of a measured one (the measured plus doffs):
  /// what disparity ranges and depths are judged by.
  double TrueDisparity(double measured) const { return measured + doffs; }
  /// Depth (metres) of a measured disparity d (TrueDisparity(d) > 0).
  double DepthFromDisparity(double d) const { return fx * baseline / (d + doffs); }
  /// Back-projects left pixel (u, v) with measured disparity d to the left camera frame.
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
