// rostest node: feeds the nodelet directly with good and bad stereo input and checks that bad
// input is refused with a clear warning, never stops the nodelet, and that tracking resumes
// when good frames come back. Frames come from the synthetic test recording (~bag); every
// good frame is sent only after the previous one was answered with a status message, so the
// run is deterministic on a loaded machine.
#include <algorithm>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/SaveTrajectory.h"
#include "pl_slam/TrackingStatus.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/ros/conversions.h"

namespace {

namespace enc = sensor_msgs::image_encodings;
using pl_slam::StereoFrame;

/// Everything the test talks to, shared by the test cases (they run in order and continue
/// one stream of frames).
struct Harness {
  ros::Publisher left_pub, right_pub, left_info_pub, right_info_pub;
  ros::Subscriber status_sub, odom_sub, rosout_sub;
  std::vector<StereoFrame> frames;  // rectified frames of the recording
  pl_slam::StereoCamera camera;
  std::size_t next_frame = 0;  // next frame of the recording to send
  ros::Time stamp{2000.0};     // stamp of the last pair sent
  std::mutex mutex;            // guards what the callbacks write
  std::vector<pl_slam::TrackingStatus> statuses;
  std::size_t odom_count = 0;
  std::deque<std::string> warnings;  // WARN/ERROR texts from /rosout
};

Harness* h = nullptr;

sensor_msgs::Image ToImage(const cv::Mat& grey, const std::string& encoding, ros::Time stamp,
                           const std::string& frame) {
  cv::Mat m;
  if (encoding == enc::RGB8) {
    cv::cvtColor(grey, m, cv::COLOR_GRAY2RGB);
  } else if (encoding == enc::BGR8) {
    cv::cvtColor(grey, m, cv::COLOR_GRAY2BGR);
  } else if (encoding == enc::MONO16) {
    grey.convertTo(m, CV_16UC1, 256.0);
  } else if (encoding == enc::YUV422) {
    m = cv::Mat(grey.rows, grey.cols, CV_8UC2, cv::Scalar(128, 128));  // content is irrelevant
  } else {
    m = grey;
  }
  sensor_msgs::Image msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame;
  msg.height = static_cast<uint32_t>(m.rows);
  msg.width = static_cast<uint32_t>(m.cols);
  msg.encoding = encoding;
  msg.step = static_cast<uint32_t>(m.cols * m.elemSize());
  msg.data.resize(static_cast<std::size_t>(msg.step) * m.rows);
  for (int r = 0; r < m.rows; ++r) {
    std::copy(m.ptr<uint8_t>(r), m.ptr<uint8_t>(r) + msg.step, msg.data.begin() + r * msg.step);
  }
  return msg;
}

struct PairOptions {
  std::string left_encoding = enc::MONO8;
  std::string right_encoding = enc::MONO8;
  bool send_info = true;
  double right_stamp_offset = 0.0;  // seconds added to the right image's (and info's) stamp
  cv::Size right_size;              // resize the right image (empty = keep)
  const sensor_msgs::CameraInfo* left_info = nullptr;  // default: the rectified calibration
  const sensor_msgs::CameraInfo* right_info = nullptr;
  const cv::Mat* left_image = nullptr;  // default: the next frame of the recording
  const cv::Mat* right_image = nullptr;
};

void PublishPair(ros::Time stamp, const PairOptions& o = PairOptions()) {
  const StereoFrame& f = h->frames[std::min(h->next_frame, h->frames.size() - 1)];
  cv::Mat right = o.right_image ? *o.right_image : f.right;
  if (!o.right_size.empty()) cv::resize(right, right, o.right_size);
  const ros::Time right_stamp = stamp + ros::Duration(o.right_stamp_offset);
  sensor_msgs::CameraInfo li, ri;
  pl_slam::ros_layer::StereoCameraToInfo(h->camera, "cam0", "cam1", &li, &ri);
  if (o.left_info) li = *o.left_info;
  if (o.right_info) ri = *o.right_info;
  li.header.stamp = stamp;
  ri.header.stamp = right_stamp;
  if (o.send_info) {
    h->left_info_pub.publish(li);
    h->right_info_pub.publish(ri);
  }
  h->left_pub.publish(
      ToImage(o.left_image ? *o.left_image : f.left, o.left_encoding, stamp, "cam0"));
  h->right_pub.publish(ToImage(right, o.right_encoding, right_stamp, "cam1"));
}

std::size_t StatusCount() {
  std::lock_guard<std::mutex> lock(h->mutex);
  return h->statuses.size();
}

pl_slam::TrackingStatus LastStatus() {
  std::lock_guard<std::mutex> lock(h->mutex);
  return h->statuses.empty() ? pl_slam::TrackingStatus() : h->statuses.back();
}

/// Spins until `pred` holds or `timeout` seconds pass; returns pred().
template <typename Pred>
bool WaitFor(Pred pred, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < end) {
    if (pred()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return pred();
}

/// Sends the next good frame (10 Hz stamps) and waits for its status; false on timeout.
bool SendGoodFrame(const PairOptions& o = PairOptions()) {
  const std::size_t before = StatusCount();
  h->stamp += ros::Duration(0.1);
  PublishPair(h->stamp, o);
  const bool answered = WaitFor([&] { return StatusCount() > before; }, 10.0);
  ++h->next_frame;
  return answered;
}

/// True when a warning containing `text` arrived on /rosout (within `timeout` seconds).
bool WarnedAbout(const std::string& text, double timeout) {
  return WaitFor(
      [&] {
        std::lock_guard<std::mutex> lock(h->mutex);
        return std::any_of(h->warnings.begin(), h->warnings.end(),
                           [&](const std::string& w) { return w.find(text) != std::string::npos; });
      },
      timeout);
}

/// Sends bad pairs with fresh stamps for `seconds` at 10 Hz; returns how many statuses came.
std::size_t SendBadFor(double seconds, const PairOptions& o) {
  const std::size_t before = StatusCount();
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < end) {
    h->stamp += ros::Duration(0.1);
    PublishPair(h->stamp, o);
    ros::WallDuration(0.1).sleep();
  }
  ros::WallDuration(0.5).sleep();  // anything accepted would have been processed by now
  return StatusCount() - before;
}

std::string AllWarnings() {
  std::lock_guard<std::mutex> lock(h->mutex);
  std::string all;
  for (const auto& w : h->warnings) all += "  " + w + "\n";
  return all;
}

TEST(BadInput, TracksGoodFramesFirst) {
  for (int i = 0; i < 12; ++i) ASSERT_TRUE(SendGoodFrame()) << "no status for good frame " << i;
  EXPECT_EQ(LastStatus().state_name, "TRACKING");
  std::lock_guard<std::mutex> lock(h->mutex);
  EXPECT_GE(h->odom_count, 10u);
}

TEST(BadInput, ColourAndSixteenBitImagesAreConverted) {
  const std::vector<std::string> encodings = {enc::RGB8, enc::BGR8, enc::MONO16};
  for (int i = 0; i < 9; ++i) {
    PairOptions o;
    o.left_encoding = o.right_encoding = encodings[i % 3];
    ASSERT_TRUE(SendGoodFrame(o)) << "no status for a " << o.left_encoding << " pair";
    EXPECT_EQ(LastStatus().state_name, "TRACKING") << o.left_encoding;
  }
  EXPECT_EQ(LastStatus().frames_rejected, 0u);
}

TEST(BadInput, UnsupportedEncodingIsRejectedWithAWarning) {
  PairOptions o;
  o.left_encoding = o.right_encoding = enc::YUV422;
  EXPECT_EQ(SendBadFor(1.5, o), 0u) << "a yuv422 pair was processed";
  EXPECT_TRUE(WarnedAbout("unsupported image encoding 'yuv422'", 3.0)) << AllWarnings();
}

TEST(BadInput, MismatchedImageSizesAreRejected) {
  PairOptions o;
  o.right_size = cv::Size(h->camera.width / 2, h->camera.height / 2);
  EXPECT_EQ(SendBadFor(1.5, o), 0u);
  EXPECT_TRUE(WarnedAbout("and right 376x240 images", 3.0)) << AllWarnings();
}

TEST(BadInput, MissingCameraInfoIsReported) {
  PairOptions o;
  o.send_info = false;
  EXPECT_EQ(SendBadFor(2.5, o), 0u);
  EXPECT_TRUE(WarnedAbout("camera_info is missing", 3.0)) << AllWarnings();
}

TEST(BadInput, UnsynchronisedStampsAreReported) {
  PairOptions o;
  o.right_stamp_offset = 0.02;
  EXPECT_EQ(SendBadFor(2.5, o), 0u);
  EXPECT_TRUE(WarnedAbout("header stamps differ", 3.0)) << AllWarnings();
}

TEST(BadInput, TracksAgainWhenGoodFramesReturn) {
  for (int i = 0; i < 8; ++i) ASSERT_TRUE(SendGoodFrame()) << "no status for good frame " << i;
  const pl_slam::TrackingStatus s = LastStatus();
  EXPECT_EQ(s.state_name, "TRACKING");
  EXPECT_GE(s.frames_rejected, 20u) << "bad pairs not counted";
}

// Raw input: the same frames distorted and rotated as a real camera would deliver them, with
// camera_info carrying K, D, R, P. The nodelet must rectify them back and keep tracking; the
// change of camera_info is announced.
TEST(BadInput, RawImagesAreRectifiedFromCameraInfo) {
  sensor_msgs::CameraInfo rect_l, rect_r;
  pl_slam::ros_layer::StereoCameraToInfo(h->camera, "cam0", "cam1", &rect_l, &rect_r);
  sensor_msgs::CameraInfo raw_info[2] = {rect_l, rect_r};
  cv::Mat to_raw_x[2], to_raw_y[2];
  for (int side = 0; side < 2; ++side) {
    sensor_msgs::CameraInfo& info = raw_info[side];
    info.K = {h->camera.fx * 1.02,
              0.0,
              h->camera.cx + 3.0,
              0.0,
              h->camera.fy * 1.02,
              h->camera.cy - 2.0,
              0.0,
              0.0,
              1.0};
    info.D = {-0.12, 0.03, 0.0005, -0.0003, 0.0};
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0.01, side == 0 ? 0.015 : -0.01, 0.004), R);
    for (int i = 0; i < 9; ++i) info.R[i] = R.val[i];
    // For every raw pixel, where it lies in the rectified image: raw = rectified sampled there.
    std::vector<cv::Point2f> raw_px, rect_px;
    for (int v = 0; v < h->camera.height; ++v) {
      for (int u = 0; u < h->camera.width; ++u) raw_px.emplace_back(u, v);
    }
    const cv::Matx34d P(info.P.data());
    cv::undistortPoints(raw_px, rect_px, cv::Matx33d(info.K.data()), cv::Mat(info.D), R, P);
    to_raw_x[side].create(h->camera.height, h->camera.width, CV_32FC1);
    to_raw_y[side].create(h->camera.height, h->camera.width, CV_32FC1);
    for (std::size_t i = 0; i < rect_px.size(); ++i) {
      to_raw_x[side].at<float>(static_cast<int>(i)) = rect_px[i].x;
      to_raw_y[side].at<float>(static_cast<int>(i)) = rect_px[i].y;
    }
  }
  for (int i = 0; i < 8; ++i) {
    const StereoFrame& f = h->frames[std::min(h->next_frame, h->frames.size() - 1)];
    cv::Mat raw_left, raw_right;
    cv::remap(f.left, raw_left, to_raw_x[0], to_raw_y[0], cv::INTER_LINEAR);
    cv::remap(f.right, raw_right, to_raw_x[1], to_raw_y[1], cv::INTER_LINEAR);
    PairOptions o;
    o.left_info = &raw_info[0];
    o.right_info = &raw_info[1];
    o.left_image = &raw_left;
    o.right_image = &raw_right;
    ASSERT_TRUE(SendGoodFrame(o)) << "no status for raw frame " << i;
    EXPECT_EQ(LastStatus().state_name, "TRACKING") << "raw frame " << i;
  }
  EXPECT_TRUE(WarnedAbout("camera_info changed; rectification recomputed", 2.0)) << AllWarnings();
  // And back to rectified input.
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(SendGoodFrame());
  EXPECT_EQ(LastStatus().state_name, "TRACKING");
}

TEST(BadInput, StampsGoingBackwardsResetTheMapAndTrackingResumes) {
  // A looping bag: the stream restarts from the first frame with its old stamps.
  h->next_frame = 0;
  h->stamp = ros::Time(2000.0);
  std::size_t tracking_after_reset = 0;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(SendGoodFrame()) << "no status after the loop, frame " << i;
    if (LastStatus().state_name == "TRACKING") ++tracking_after_reset;
  }
  EXPECT_TRUE(WarnedAbout("stamp went backwards", 2.0)) << AllWarnings();
  EXPECT_GE(tracking_after_reset, 8u);
  // The map was reset: the trajectory holds only the frames since the loop.
  pl_slam::SaveTrajectory save;
  save.request.path = "/tmp/pl_slam_bad_input_" + std::to_string(::getpid()) + ".tum";
  ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  EXPECT_LE(save.response.poses, 10u);
  EXPECT_GE(save.response.poses, 8u);
  std::remove(save.request.path.c_str());

  // A repeated stamp is skipped with a warning.
  const std::size_t before = StatusCount();
  PublishPair(h->stamp);
  EXPECT_TRUE(WarnedAbout("same stamp as the previous one", 3.0)) << AllWarnings();
  EXPECT_EQ(StatusCount(), before);
  ASSERT_TRUE(SendGoodFrame());
  EXPECT_EQ(LastStatus().state_name, "TRACKING");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "bad_input_test");
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();

  Harness harness;
  h = &harness;
  std::string bag;
  if (!pnh.getParam("bag", bag)) {
    ROS_FATAL("bad_input_test needs ~bag (the synthetic test recording)");
    return 1;
  }
  {
    pl_slam::ros_layer::BagStereoSource source(bag);
    harness.camera = source.camera();
    StereoFrame f;
    while (harness.frames.size() < 60 && source.Next(&f)) harness.frames.push_back(f);
  }
  harness.left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 5);
  harness.right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 5);
  harness.left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 5);
  harness.right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 5);
  harness.status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 100, [&harness](const pl_slam::TrackingStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.statuses.push_back(*m);
      });
  harness.odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/pl_slam/odom", 100, [&harness](const nav_msgs::Odometry::ConstPtr&) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        ++harness.odom_count;
      });
  harness.rosout_sub = nh.subscribe<rosgraph_msgs::Log>(
      "/rosout", 100, [&harness](const rosgraph_msgs::Log::ConstPtr& m) {
        if (m->level < rosgraph_msgs::Log::WARN) return;
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.warnings.push_back(m->msg);
      });
  // Wait until the nodelet listens on all four inputs and publishes status.
  const bool connected = WaitFor(
      [&] {
        return harness.left_pub.getNumSubscribers() > 0 &&
               harness.right_pub.getNumSubscribers() > 0 &&
               harness.left_info_pub.getNumSubscribers() > 0 &&
               harness.right_info_pub.getNumSubscribers() > 0 &&
               harness.status_sub.getNumPublishers() > 0 &&
               harness.rosout_sub.getNumPublishers() > 0;
      },
      60.0);
  if (!connected) {
    ROS_FATAL("bad_input_test: the nodelet did not subscribe to the inputs within 60 s");
    return 1;
  }
  ros::WallDuration(1.0).sleep();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
