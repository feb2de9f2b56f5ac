// Map and feature visualisation for the ROS layer: rviz markers and the keyframe path from a
// map snapshot, and the debug image of the last frame's features. Pure conversions (no
// publishing, no ROS node needed), so they are unit-tested without a master.
#pragma once

#include <string>

#include <geometry_msgs/PoseArray.h>
#include <nav_msgs/Path.h>
#include <opencv2/core.hpp>
#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>

#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/map/map.h"

namespace pl_slam {
namespace ros_layer {

/// Marker namespaces on ~markers (one marker each, id 0): keep these names stable.
inline constexpr const char* kPointsNs = "points";              ///< POINTS, map points
inline constexpr const char* kLinesNs = "lines";                ///< LINE_LIST, 3D segments
inline constexpr const char* kKeyframesNs = "keyframes";        ///< LINE_LIST, frustums
inline constexpr const char* kCovisibilityNs = "covisibility";  ///< LINE_LIST, centre to centre
inline constexpr const char* kLoopEdgesNs = "loop_edges";       ///< LINE_LIST, centre to centre

/// The map as rviz markers in `frame`. `T_frame_w` takes the SLAM world (the first left
/// camera's optical frame) to `frame`, and `T_base_cam` is the camera mount, so that the
/// markers line up with the poses the nodelet publishes. A namespace with nothing to show
/// gets a DELETE (rviz warns about empty POINTS/LINE_LIST markers).
visualization_msgs::MarkerArray MakeMapMarkers(const MapSnapshot& map, const SE3& T_frame_w,
                                               const std::string& frame, const ros::Time& stamp);

/// The keyframe trajectory of `map` as base poses in `frame`: T_frame_w * T_w_kf * T_cam_base
/// with T_cam_base = T_base_cam^-1, stamped with the keyframe stamps, in keyframe order.
nav_msgs::Path MakeKeyframePath(const MapSnapshot& map, const SE3& T_frame_w, const SE3& T_base_cam,
                                const std::string& frame);

/// The map as a cloud for downstream nodes (planners, costmaps): fields x, y, z (float32) and
/// `source` (uint8: 0 a map point, 1 a sample of a 3D segment) in `frame`, the map points
/// first. With `segment_step` > 0 every segment is also sampled every segment_step metres
/// (both endpoints included); 0 = points only.
sensor_msgs::PointCloud2 MakeMapCloud(const MapSnapshot& map, const SE3& T_frame_w,
                                      const std::string& frame, const ros::Time& stamp,
                                      double segment_step);

/// The keyframes' base poses in `frame` (as MakeKeyframePath), in keyframe order.
geometry_msgs::PoseArray MakeKeyframePoses(const MapSnapshot& map, const SE3& T_frame_w,
                                           const SE3& T_base_cam, const std::string& frame,
                                           const ros::Time& stamp);

/// The debug image: `left` (mono8, rectified, the pixels the features are in) as bgr8 with
/// points as small circles and segments as lines, green with depth (stereo match) and yellow
/// without, and `status` written on a dark band at the top.
cv::Mat DrawDebugImage(const cv::Mat& left, const StereoFeatures& features,
                       const std::string& status);

}  // namespace ros_layer
}  // namespace pl_slam
