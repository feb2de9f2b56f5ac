// rostest node: the nodelet's /diagnostics. Frames of the synthetic test recording are sent at
// the expected 10 Hz (input and tracking OK), then at 5 Hz (input WARN: half the rate), then
// blank frames at 10 Hz (tracking ERROR once lost for over a second).
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "test_util/stereo_feed.h"

namespace {

struct Harness {
  pl_slam::testing_util::StereoFeed feed;
  ros::Time stamp{3000.0};
  std::mutex mutex;
  // Levels of the nodelet's "input" and "tracking" statuses seen since the last Clear().
  std::vector<int> input_levels, tracking_levels;
};

Harness* h = nullptr;

void Send(const cv::Mat& left, const cv::Mat& right, double period_s) {
  h->stamp += ros::Duration(period_s);
  h->feed.Publish(left, right, h->stamp);
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
  for (int i = 0; i < 30; ++i, ++next)
    Send(h->feed.frames[next].left, h->feed.frames[next].right, 0.1);
  EXPECT_TRUE(Saw(h->input_levels, DiagnosticStatus::OK)) << "input never OK at 10 Hz";
  EXPECT_TRUE(Saw(h->tracking_levels, DiagnosticStatus::OK)) << "tracking never OK";
  // Half the rate: the last reports are WARN.
  Clear();
  for (int i = 0; i < 15; ++i, ++next)
    Send(h->feed.frames[next].left, h->feed.frames[next].right, 0.2);
  EXPECT_TRUE(Saw(h->input_levels, DiagnosticStatus::WARN)) << "no WARN at half the rate";
  // Blank frames: lost, then ERROR after a second.
  Clear();
  const cv::Mat blank(h->feed.frames[0].left.size(), CV_8UC1, cv::Scalar(120));
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
  if (!harness.feed.Open(nh, pnh, 50, 50, "diagnostics_test")) return 1;
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
  pl_slam::testing_util::WaitFor(
      [&] { return harness.feed.Connected() && diag_sub.getNumPublishers() > 0; }, 30.0);
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
