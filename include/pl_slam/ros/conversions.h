// Conversions between ROS messages and the core types. Everything ROS-specific about images
// and calibration lives here so the nodelet, the bag reader and the tools agree.
#pragma once

#include <string>

#include <geometry_msgs/Pose.h>
#include <opencv2/core.hpp>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {
namespace ros_layer {

/// Converts an image message to CV_8UC1. mono8 is shared without a copy; mono16 is scaled
/// (>> 8); rgb8, bgr8, rgba8, bgra8 are converted to grey. Other encodings throw InputError
/// naming the encoding.
cv::Mat ImageToMono8(const sensor_msgs::Image& msg);

/// Builds the rectified stereo camera from the two camera_info messages' projection matrices
/// (P): fx = P[0], cx = P[2], fy = P[5], cy = P[6], baseline = -P_right[3] / P_right[0].
/// Throws InputError when P is missing/zero, the intrinsics differ between the two, the
/// baseline is not positive or sizes differ.
StereoCamera StereoCameraFromInfo(const sensor_msgs::CameraInfo& left,
                                  const sensor_msgs::CameraInfo& right);

/// The pair of rectified camera_info messages describing `camera` (zero distortion, R = I).
void StereoCameraToInfo(const StereoCamera& camera, const std::string& left_frame,
                        const std::string& right_frame, sensor_msgs::CameraInfo* left,
                        sensor_msgs::CameraInfo* right);

/// Nanoseconds since the epoch of a ROS time.
inline int64_t ToNanoseconds(const ros::Time& t) { return static_cast<int64_t>(t.toNSec()); }
/// ROS time of a nanosecond stamp (clamped to ROS' valid range, which starts at 0).
ros::Time FromNanoseconds(int64_t ns);

/// geometry_msgs/Pose <-> SE3.
geometry_msgs::Pose ToPoseMsg(const SE3& T);
SE3 FromPoseMsg(const geometry_msgs::Pose& pose);

}  // namespace ros_layer
}  // namespace pl_slam
