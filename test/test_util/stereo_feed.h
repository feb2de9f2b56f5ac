// For rostest nodes that feed the nodelet directly: the frames of the synthetic test
// recording and publishers of its four inputs (mono8 images and rectified camera_info on
// /cam0, /cam1, the launch files' remapping).
#pragma once

#include <string>
#include <vector>

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/ros/bag_io.h"
#include "pl_slam/ros/conversions.h"

namespace pl_slam {
namespace testing_util {

/// A mono8 image message of `grey`.
inline sensor_msgs::Image MonoImage(const cv::Mat& grey, ros::Time stamp,
                                    const std::string& frame) {
  sensor_msgs::Image msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame;
  msg.height = static_cast<uint32_t>(grey.rows);
  msg.width = static_cast<uint32_t>(grey.cols);
  msg.encoding = sensor_msgs::image_encodings::MONO8;
  msg.step = static_cast<uint32_t>(grey.cols);
  msg.data.resize(static_cast<size_t>(msg.step) * grey.rows);
  for (int r = 0; r < grey.rows; ++r)
    std::copy(grey.ptr<uint8_t>(r), grey.ptr<uint8_t>(r) + msg.step,
              msg.data.begin() + static_cast<size_t>(r) * msg.step);
  return msg;
}

/// Spins (sleeping 10 ms) until `pred` holds or `timeout_s` seconds pass; returns pred().
template <typename Pred>
bool WaitFor(Pred pred, double timeout_s) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < end) {
    if (pred()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return pred();
}

/// The recording's first frames and the publishers that send them.
struct StereoFeed {
  ros::Publisher left_pub, right_pub, left_info_pub, right_info_pub;
  std::vector<StereoFrame> frames;
  StereoCamera camera;

  /// Reads up to max_frames frames of the bag named by the private parameter ~bag and
  /// advertises the inputs; false (with a FATAL line naming `who`) without ~bag or when the
  /// bag holds fewer than min_frames.
  bool Open(ros::NodeHandle& nh, const ros::NodeHandle& pnh, size_t min_frames, size_t max_frames,
            const char* who) {
    std::string bag;
    if (!pnh.getParam("bag", bag)) {
      ROS_FATAL("%s needs ~bag (the synthetic test recording)", who);
      return false;
    }
    ros_layer::BagStereoSource source(bag);
    camera = source.camera();
    StereoFrame f;
    while (frames.size() < max_frames && source.Next(&f)) frames.push_back(f);
    if (frames.size() < min_frames) {
      ROS_FATAL("%s: %s has %zu frames, fewer than %zu", who, bag.c_str(), frames.size(),
                min_frames);
      return false;
    }
    left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 5);
    right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 5);
    left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 5);
    right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 5);
    return true;
  }

  /// Publishes a stereo pair with its camera_info, all stamped `stamp`.
  void Publish(const cv::Mat& left, const cv::Mat& right, ros::Time stamp) const {
    sensor_msgs::CameraInfo li, ri;
    ros_layer::StereoCameraToInfo(camera, "cam0", "cam1", &li, &ri);
    li.header.stamp = ri.header.stamp = stamp;
    left_info_pub.publish(li);
    right_info_pub.publish(ri);
    left_pub.publish(MonoImage(left, stamp, "cam0"));
    right_pub.publish(MonoImage(right, stamp, "cam1"));
  }

  /// True once the nodelet subscribes to all four inputs.
  bool Connected() const {
    return left_pub.getNumSubscribers() > 0 && right_pub.getNumSubscribers() > 0 &&
           left_info_pub.getNumSubscribers() > 0 && right_info_pub.getNumSubscribers() > 0;
  }
};

}  // namespace testing_util
}  // namespace pl_slam
