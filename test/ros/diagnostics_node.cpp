// rostest node: the nodelet's /diagnostics. Frames of the synthetic test recording are sent at
// the expected 10 Hz (input and tracking OK), then at 5 Hz (input WARN: half the rate), then
// blank frames at 10 Hz (tracking ERROR once lost for over a second).
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/ros/bag_io.h"
#include "pl_slam/ros/conversions.h"

namespace {

struct Harness {
  ros::Publisher left_pub, right_pub, left_info_pub, right_info_pub;
  std::vector<pl_slam::StereoFrame> frames;
  pl_slam::StereoCamera camera;
  ros::Time stamp{3000.0};
  std::mutex mutex;
  // Levels of the nodelet's "input" and "tracking" statuses seen since the last Clear().
  std::vector<int> input_levels, tracking_levels;
};

Harness* h = nullptr;

sensor_msgs::Image ToImage(const cv::Mat& grey, ros::Time stamp, const std::string& frame) {
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

void Send(const cv::Mat& left, const cv::Mat& right, double period_s) {
  h->stamp += ros::Duration(period_s);
  sensor_msgs::CameraInfo li, ri;
  pl_slam::ros_layer::StereoCameraToInfo(h->camera, "cam0", "cam1", &li, &ri);
  li.header.stamp = ri.header.stamp = h->stamp;
  h->left_info_pub.publish(li);
  h->right_info_pub.publish(ri);
  h->left_pub.publish(ToImage(left, h->stamp, "cam0"));
  h->right_pub.publish(ToImage(right, h->stamp, "cam1"));
  ros::WallDuration(period_s).sleep();
}

void Clear() {
  std::lock_guard<std::mutex> lock(h->mutex);
  h->input_levels.clear();
  h->tracking_levels.clear();
}

bool Saw(const std::vector<int>& levels, int level) {
  std::lock_guard<std::mutex> lock(h->mutex);
  for (int l : levels)
    if (l == level) return true;
  return false;
}

TEST(Diagnostics, RateAndTrackingAreReported) {
  using diagnostic_msgs::DiagnosticStatus;
  size_t next = 0;
  // At the expected rate.
  for (int i = 0; i < 30; ++i, ++next) Send(h->frames[next].left, h->frames[next].right, 0.1);
  EXPECT_TRUE(Saw(h->input_levels, DiagnosticStatus::OK)) << "input never OK at 10 Hz";
  EXPECT_TRUE(Saw(h->tracking_levels, DiagnosticStatus::OK)) << "tracking never OK";
  // Half the rate: the last reports are WARN.
  Clear();
  for (int i = 0; i < 15; ++i, ++next) Send(h->frames[next].left, h->frames[next].right, 0.2);
  EXPECT_TRUE(Saw(h->input_levels, DiagnosticStatus::WARN)) << "no WARN at half the rate";
  // Blank frames: lost, then ERROR after a second.
  Clear();
  const cv::Mat blank(h->frames[0].left.size(), CV_8UC1, cv::Scalar(120));
  for (int i = 0; i < 30; ++i) Send(blank, blank, 0.1);
  EXPECT_TRUE(Saw(h->tracking_levels, DiagnosticStatus::ERROR)) << "no ERROR while lost";
  EXPECT_FALSE(Saw(h->input_levels, DiagnosticStatus::ERROR)) << "input ERROR at full rate";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "diagnostics_test");
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Harness harness;
  h = &harness;
  std::string bag;
  if (!pnh.getParam("bag", bag)) {
    ROS_FATAL("diagnostics_test needs ~bag (the synthetic test recording)");
    return 1;
  }
  {
    pl_slam::ros_layer::BagStereoSource source(bag);
    harness.camera = source.camera();
    pl_slam::StereoFrame f;
    while (harness.frames.size() < 50 && source.Next(&f)) harness.frames.push_back(f);
  }
  if (harness.frames.size() < 50) {
    ROS_FATAL("diagnostics_test: the recording has fewer than 50 frames");
    return 1;
  }
  harness.left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 5);
  harness.right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 5);
  harness.left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 5);
  harness.right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 5);
  ros::Subscriber diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&harness](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        for (const auto& s : m->status) {
          const auto ends = [&s](const std::string& suffix) {
            return s.name.size() >= suffix.size() &&
                   s.name.compare(s.name.size() - suffix.size(), suffix.size(), suffix) == 0;
          };
          if (ends(": input")) harness.input_levels.push_back(s.level);
          if (ends(": tracking")) harness.tracking_levels.push_back(s.level);
        }
      });
  // Wait until the nodelet listens on the images and reports.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && ros::WallTime::now() < end &&
         (harness.left_pub.getNumSubscribers() == 0 || harness.right_pub.getNumSubscribers() == 0 ||
          harness.left_info_pub.getNumSubscribers() == 0 || diag_sub.getNumPublishers() == 0))
    ros::WallDuration(0.05).sleep();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
