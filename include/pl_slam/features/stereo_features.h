// Features of one rectified stereo frame: points and line segments of the left image, with
// their stereo-triangulated 3D positions in the left camera frame when a stereo match exists.
#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <opencv2/core.hpp>

namespace pl_slam {

/// A keypoint of the left image.
struct PointFeature {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();   ///< left-image pixel
  int octave = 0;                                 ///< pyramid level it was detected at
  bool has_depth = false;                         ///< stereo match found and triangulated
  double disparity = 0.0;                         ///< u_left - u_right when has_depth
  Eigen::Vector3d p_c = Eigen::Vector3d::Zero();  ///< 3D point, left camera frame (has_depth)

  /// Column of the stereo match in the right image; NaN without one.
  double u_right() const {
    return has_depth ? uv.x() - disparity : std::numeric_limits<double>::quiet_NaN();
  }
};

/// A line segment of the left image.
struct LineFeature {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector2d s = Eigen::Vector2d::Zero();  ///< start point, left-image pixels
  Eigen::Vector2d e = Eigen::Vector2d::Zero();  ///< end point, left-image pixels
  /// Infinite line through s and e, l = (s,1) x (e,1) scaled so l(0)^2 + l(1)^2 = 1: then
  /// l . (u, v, 1) is the signed pixel distance of (u, v) to the line.
  Eigen::Vector3d l = Eigen::Vector3d::Zero();
  double angle = 0.0;      ///< direction atan2(e - s), radians
  double length = 0.0;     ///< pixels
  int octave = 0;          ///< pyramid level it was detected at
  bool has_depth = false;  ///< stereo match found, both endpoints triangulated
  /// With depth although flatter than the row crossing allows: the endpoints took the
  /// disparities of the segments they meet at L junctions (LineMatchingOptions::junction_max_px)
  bool depth_from_junctions = false;
  /// Of those, one with a single L junction (LineMatchingOptions::junction_one_end): the free
  /// end's disparity is that of its own patch, found along its row in the right image
  bool one_junction = false;
  Eigen::Vector3d P_c = Eigen::Vector3d::Zero();  ///< 3D start point, left camera frame
  Eigen::Vector3d Q_c = Eigen::Vector3d::Zero();  ///< 3D end point, left camera frame
};

using PointFeatures = std::vector<PointFeature, Eigen::aligned_allocator<PointFeature>>;
using LineFeatures = std::vector<LineFeature, Eigen::aligned_allocator<LineFeature>>;

/// All features of one stereo frame. Descriptor row i belongs to feature i.
struct StereoFeatures {
  PointFeatures points;
  cv::Mat point_descriptors;  ///< CV_8U, 32 bytes per row (ORB)
  LineFeatures lines;
  cv::Mat line_descriptors;  ///< CV_8U, 32 bytes per row (LBD)
};

}  // namespace pl_slam
