// rostest node: every image sent is accounted for. Bursts of stereo pairs, published back to
// back (far faster than the worker processes them), with lone left and right images and pairs
// of the wrong size among them; ~status and /diagnostics must count exactly what was sent as
// received, and every image received as processed, dropped, rejected or unpaired.
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "pl_slam/TrackingStatus.h"
#include "test_util/stereo_feed.h"

namespace {

constexpr int kBursts = 8;
constexpr int kPairsPerBurst = 24;  // under the default queue_size (30): a burst loses nothing

struct Harness {
  pl_slam::testing_util::StereoFeed feed;
  std::mutex mutex;
  std::vector<pl_slam::TrackingStatus> statuses;
  std::map<std::string, long> input_values;  // the last "input" diagnostics, numbers only
  ros::Subscriber status_sub, diag_sub;
};

Harness* h = nullptr;

long Value(const std::string& key) {
  std::lock_guard<std::mutex> lock(h->mutex);
  const auto it = h->input_values.find(key);
  return it == h->input_values.end() ? -1 : it->second;
}

TEST(InputAccounting, EveryImageOfBurstyInputIsCounted) {
  uint32_t sent_left = 0, sent_right = 0, lone_left = 0, lone_right = 0, bad_pairs = 0;
  ros::Time stamp(5000.0);
  const auto& frames = h->feed.frames;
  const cv::Mat small(frames[0].left.rows / 2, frames[0].left.cols / 2, CV_8UC1, cv::Scalar(90));
  size_t next = 0;
  for (int b = 0; b < kBursts; ++b) {
    for (int i = 0; i < kPairsPerBurst; ++i) {
      stamp += ros::Duration(0.1);
      if (i == 7) {  // a left image whose partner never comes
        h->feed.left_pub.publish(pl_slam::testing_util::MonoImage(
            frames[next].left, stamp - ros::Duration(0.05), "cam0"));
        ++sent_left, ++lone_left;
      }
      if (i == 13) {  // a right one
        h->feed.right_pub.publish(pl_slam::testing_util::MonoImage(
            frames[next].right, stamp - ros::Duration(0.05), "cam1"));
        ++sent_right, ++lone_right;
      }
      if (i == 17 && b % 2 == 0) {  // images of the wrong size: refused as bad input
        h->feed.Publish(small, small, stamp);
        ++bad_pairs;
      } else {
        h->feed.Publish(frames[next].left, frames[next].right, stamp);
        next = (next + 1) % frames.size();
      }
      ++sent_left, ++sent_right;
    }
    ros::WallDuration(0.4).sleep();
  }
  // Settled: everything sent has arrived and nothing waits or is in progress.
  const bool settled = pl_slam::testing_util::WaitFor(
      [&] {
        return Value("left images received") == sent_left &&
               Value("right images received") == sent_right && Value("left images waiting") == 0 &&
               Value("right images waiting") == 0 && Value("pairs in progress") == 0;
      },
      30.0);
  // The diagnostics can count the last frame processed before its status message is out (the
  // worker publishes the status after the pose and TF): wait for that message too.
  const bool last_status = pl_slam::testing_util::WaitFor(
      [&] {
        const long processed = Value("frames processed");
        std::lock_guard<std::mutex> lock(h->mutex);
        return !h->statuses.empty() &&
               static_cast<long>(h->statuses.back().frame_index) == processed;
      },
      10.0);
  const long processed = Value("frames processed"),
             dropped = Value("frames dropped (worker behind)"),
             rejected = Value("frames rejected (bad input)");
  const long left_received = Value("left images received"),
             right_received = Value("right images received");
  const long left_unpaired = Value("left images unpaired"),
             right_unpaired = Value("right images unpaired");
  char counts[400];
  std::snprintf(
      counts, sizeof(counts),
      "sent %u left, %u right (%u lone left, %u lone right, %u bad pairs); received %ld left, "
      "%ld right; processed %ld, dropped %ld, rejected %ld, unpaired %ld left, %ld right; "
      "waiting %ld left, %ld right; in progress %ld",
      sent_left, sent_right, lone_left, lone_right, bad_pairs, left_received, right_received,
      processed, dropped, rejected, left_unpaired, right_unpaired, Value("left images waiting"),
      Value("right images waiting"), Value("pairs in progress"));
  std::printf("%s\n", counts);
  SCOPED_TRACE(counts);  // every failure below says what the counts were
  ASSERT_TRUE(settled) << "the diagnostics never showed every image sent as received and "
                          "accounted for";
  EXPECT_EQ(left_received, processed + dropped + rejected + left_unpaired);
  EXPECT_EQ(right_received, processed + dropped + rejected + right_unpaired);
  // The bursts outran the worker, and what it could not take was dropped, not lost.
  EXPECT_GT(dropped, 0);
  EXPECT_GT(processed, 0);
  // Every lone image is unpaired; a pair broken in the synchroniser costs each camera one.
  EXPECT_GE(left_unpaired, lone_left);
  EXPECT_GE(right_unpaired, lone_right);
  EXPECT_EQ(left_unpaired - lone_left, right_unpaired - lone_right);
  EXPECT_GT(rejected, 0);
  EXPECT_LE(rejected, bad_pairs);
  // Every status message balances on its own (one snapshot per message).
  EXPECT_TRUE(last_status) << "no status message for the last frame processed";
  std::lock_guard<std::mutex> lock(h->mutex);
  ASSERT_FALSE(h->statuses.empty());
  for (const auto& s : h->statuses) {
    const uint32_t pairs =
        s.frame_index + s.frames_dropped + s.frames_rejected + s.pairs_in_progress;
    EXPECT_EQ(s.left_received, pairs + s.left_unpaired + s.left_waiting)
        << "frame " << s.frame_index;
    EXPECT_EQ(s.right_received, pairs + s.right_unpaired + s.right_waiting)
        << "frame " << s.frame_index;
  }
  EXPECT_EQ(static_cast<long>(h->statuses.back().frame_index), processed);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "input_accounting_test");
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Harness harness;
  h = &harness;
  if (!harness.feed.Open(nh, pnh, 50, 120, "input_accounting_test")) return 1;
  // Queues deep enough that this side never drops a message of a burst (the feed's queue-5
  // publications are shut down first, or roscpp would keep using them).
  harness.feed.left_pub.shutdown();
  harness.feed.right_pub.shutdown();
  harness.feed.left_info_pub.shutdown();
  harness.feed.right_info_pub.shutdown();
  harness.feed.left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 1000);
  harness.feed.right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 1000);
  harness.feed.left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 1000);
  harness.feed.right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 1000);
  harness.status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&harness](const pl_slam::TrackingStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.statuses.push_back(*m);
      });
  harness.diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&harness](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const auto& s : m->status) {
          const std::string suffix = ": input";
          if (s.name.size() < suffix.size() ||
              s.name.compare(s.name.size() - suffix.size(), suffix.size(), suffix) != 0)
            continue;
          std::lock_guard<std::mutex> lock(harness.mutex);
          for (const auto& kv : s.values) {
            try {
              harness.input_values[kv.key] = std::stol(kv.value);
            } catch (const std::exception&) {
            }
          }
        }
      });
  if (!pl_slam::testing_util::WaitFor(
          [&] {
            return harness.feed.Connected() && harness.status_sub.getNumPublishers() > 0 &&
                   harness.diag_sub.getNumPublishers() > 0;
          },
          60.0)) {
    ROS_FATAL("input_accounting_test: the nodelet did not subscribe to the inputs within 60 s");
    return 1;
  }
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
