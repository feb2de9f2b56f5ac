// rostest node: the nodelet's bookkeeping over its life. Fed directly with frames of the
// synthetic test recording (~bag), restamped onto a EuRoC-like clock whose stamps a double
// cannot hold to the nanosecond, one frame at a time (each sent after the previous status), it
// checks that saved trajectories carry the exact image stamps, that ~reset restarts the
// counters and clears ~path and ~markers at once, that stamp jitter is skipped without a reset,
// and that a backwards stamp in localisation-only mode keeps the map.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>

#include "pl_slam/SaveTrajectory.h"
#include "pl_slam/TrackingStatus.h"
#include "test_util/stereo_feed.h"

namespace {

using pl_slam::StereoFrame;

// A EuRoC MH_01 image stamp: as seconds in a double (ns * 1e-9) it reads 1403636579.763555765.
constexpr int64_t kFirstStampNs = 1403636579763555584;

struct Harness {
  pl_slam::testing_util::StereoFeed feed;
  ros::Subscriber status_sub, path_sub, markers_sub, rosout_sub;
  std::size_t next_frame = 0;
  std::size_t map_start_frame = 0;   // the recording's frame the map after ~reset starts at
  int64_t stamp_ns = kFirstStampNs;  // stamp of the next pair
  std::set<int64_t> sent;            // stamps of the pairs sent
  std::mutex mutex;
  std::vector<pl_slam::TrackingStatus> statuses;
  std::vector<std::pair<ros::WallTime, nav_msgs::Path>> paths;
  std::vector<std::pair<ros::WallTime, visualization_msgs::MarkerArray>> markers;
  std::vector<std::string> warnings;
};

Harness* h = nullptr;

void PublishPair(int64_t stamp_ns) {
  const StereoFrame& f = h->feed.frames[h->next_frame % h->feed.frames.size()];
  ros::Time stamp;
  stamp.fromNSec(static_cast<uint64_t>(stamp_ns));
  h->feed.Publish(f.left, f.right, stamp);
}

std::size_t StatusCount() {
  std::lock_guard<std::mutex> lock(h->mutex);
  return h->statuses.size();
}

pl_slam::TrackingStatus LastStatus() {
  std::lock_guard<std::mutex> lock(h->mutex);
  return h->statuses.empty() ? pl_slam::TrackingStatus() : h->statuses.back();
}

using pl_slam::testing_util::WaitFor;

/// Sends the next frame of the recording 50 ms (plus a few odd nanoseconds) after the last
/// one and waits for its status.
bool SendFrame() {
  const std::size_t before = StatusCount();
  PublishPair(h->stamp_ns);
  h->sent.insert(h->stamp_ns);
  h->stamp_ns += 50000000 + 37;
  ++h->next_frame;
  return WaitFor([&] { return StatusCount() > before; }, 15.0);
}

bool WarnedAbout(const std::string& text, double timeout) {
  return WaitFor(
      [&] {
        std::lock_guard<std::mutex> lock(h->mutex);
        return std::any_of(h->warnings.begin(), h->warnings.end(),
                           [&](const std::string& w) { return w.find(text) != std::string::npos; });
      },
      timeout);
}

/// The integer nanosecond stamps of a saved trajectory file, read as text (no double).
std::vector<int64_t> ReadStampsNs(const std::string& path, bool tum) {
  std::vector<int64_t> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::string field = line.substr(0, line.find(tum ? ' ' : ','));
    if (tum) {
      const std::size_t dot = field.find('.');
      if (dot == std::string::npos || field.size() - dot - 1 != 9) {
        ADD_FAILURE() << "TUM stamp '" << field << "' has not 9 decimals";
        continue;
      }
      field.erase(dot, 1);
    }
    out.push_back(std::stoll(field));
  }
  return out;
}

TEST(Lifecycle, SavedTrajectoriesCarryTheExactImageStamps) {
  for (int i = 0; i < 25; ++i) ASSERT_TRUE(SendFrame()) << "no status for frame " << i;
  ASSERT_EQ(LastStatus().state, pl_slam::TrackingStatus::TRACKING);
  for (const char* format : {"tum", "euroc"}) {
    pl_slam::SaveTrajectory save;
    save.request.path =
        "/tmp/pl_slam_lifecycle_" + std::to_string(::getpid()) + "." + std::string(format);
    save.request.format = format;
    ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
    ASSERT_TRUE(save.response.success) << save.response.message;
    const std::vector<int64_t> saved = ReadStampsNs(save.request.path, format[0] == 't');
    std::remove(save.request.path.c_str());
    EXPECT_GE(saved.size(), 20u) << format;
    EXPECT_EQ(saved.size(), save.response.poses) << format;
    std::size_t exact = 0;
    for (int64_t ns : saved) {
      if (h->sent.count(ns)) {
        ++exact;
      } else {
        ADD_FAILURE() << format << ": saved stamp " << ns << " is no image's stamp";
      }
    }
    EXPECT_EQ(exact, saved.size()) << format;
    if (!saved.empty()) EXPECT_EQ(saved.front(), kFirstStampNs) << format;
  }
}

TEST(Lifecycle, SmallBackwardsJitterIsSkippedWithoutAReset) {
  const pl_slam::TrackingStatus before = LastStatus();
  const std::size_t count = StatusCount();
  PublishPair(h->stamp_ns - 300000000);  // 0.3 s back: below backwards_stamp_reset_after (1 s)
  EXPECT_TRUE(WarnedAbout("before the previous one skipped", 5.0));
  EXPECT_EQ(StatusCount(), count) << "a jittered frame was processed";
  ASSERT_TRUE(SendFrame());
  const pl_slam::TrackingStatus after = LastStatus();
  EXPECT_EQ(after.state, pl_slam::TrackingStatus::TRACKING);
  EXPECT_GE(after.keyframes, before.keyframes) << "the map was reset by jitter";
  EXPECT_EQ(after.frame_index, before.frame_index + 1);
  EXPECT_GE(after.frames_rejected, before.frames_rejected + 1) << "the skipped frame not counted";
}

TEST(Lifecycle, ResetRestartsTheCountersAndClearsPathAndMarkersAtOnce) {
  // A repeated stamp: refused and counted, so frames_rejected is not 0 before the reset.
  PublishPair(h->stamp_ns - 50000000 - 37);
  ASSERT_TRUE(SendFrame());
  const pl_slam::TrackingStatus before = LastStatus();
  ASSERT_GE(before.frame_index, 25u);
  ASSERT_GE(before.frames_rejected, 1u);
  const ros::WallTime reset_time = ros::WallTime::now();
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call("/pl_slam/reset", reset));
  EXPECT_TRUE(reset.response.success) << reset.response.message;
  // Without a new frame: an empty ~path and a DELETEALL ~markers.
  const bool cleared_path = WaitFor(
      [&] {
        std::lock_guard<std::mutex> lock(h->mutex);
        return std::any_of(h->paths.begin(), h->paths.end(), [&](const auto& p) {
          return p.first >= reset_time && p.second.poses.empty();
        });
      },
      5.0);
  EXPECT_TRUE(cleared_path) << "no empty ~path after the reset";
  const bool cleared_markers = WaitFor(
      [&] {
        std::lock_guard<std::mutex> lock(h->mutex);
        return std::any_of(h->markers.begin(), h->markers.end(), [&](const auto& m) {
          return m.first >= reset_time && !m.second.markers.empty() &&
                 m.second.markers[0].action == visualization_msgs::Marker::DELETEALL;
        });
      },
      5.0);
  EXPECT_TRUE(cleared_markers) << "no DELETEALL ~markers after the reset";
  h->map_start_frame = h->next_frame;
  ASSERT_TRUE(SendFrame());
  const pl_slam::TrackingStatus after = LastStatus();
  EXPECT_EQ(after.frame_index, 1u) << "frame_index kept counting across the reset";
  EXPECT_EQ(after.frames_rejected, 0u);
  EXPECT_EQ(after.frames_dropped, 0u);
  EXPECT_EQ(after.loops, 0u);
  EXPECT_LE(after.keyframes, 1u) << "the map was not cleared";
}

TEST(Lifecycle, BackwardsStampInLocalisationOnlyModeKeepsTheMap) {
  // Map again from the reset, then switch to localisation only (no map_file: the map is
  // only in memory, so a reset would lose it).
  for (int i = 0; i < 34; ++i) ASSERT_TRUE(SendFrame()) << "no status for frame " << i;
  ASSERT_GE(LastStatus().keyframes, 3u);
  std_srvs::SetBool loc;
  loc.request.data = true;
  ASSERT_TRUE(ros::service::call("/pl_slam/set_localization_only", loc));
  ASSERT_TRUE(loc.response.success) << loc.response.message;
  ros::WallDuration(1.0).sleep();  // local mapping finishes the keyframes it was given
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(SendFrame());
  const pl_slam::TrackingStatus before = LastStatus();
  ASSERT_TRUE(before.localization_only);
  // The recording again from where the map starts, 100 s back in time (a looping bag).
  h->next_frame = h->map_start_frame;
  h->stamp_ns -= 100 * 1000000000LL;
  const std::size_t first = StatusCount();
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(SendFrame()) << "no status after the jump, frame " << i;
  EXPECT_TRUE(WarnedAbout("keeping the map", 5.0));
  std::vector<pl_slam::TrackingStatus> after;
  {
    std::lock_guard<std::mutex> lock(h->mutex);
    after.assign(h->statuses.begin() + static_cast<std::ptrdiff_t>(first), h->statuses.end());
  }
  std::size_t relocalised = 0, tracking = 0;
  for (const auto& s : after) {
    EXPECT_EQ(s.keyframes, before.keyframes) << "frame " << s.frame_index;
    EXPECT_EQ(s.point_landmarks, before.point_landmarks) << "frame " << s.frame_index;
    EXPECT_EQ(s.line_landmarks, before.line_landmarks) << "frame " << s.frame_index;
    EXPECT_TRUE(s.localization_only);
    if (s.relocalized) ++relocalised;
    if (s.state == pl_slam::TrackingStatus::TRACKING) ++tracking;
  }
  std::cout << "[lifecycle] map " << before.keyframes << " keyframes, " << before.point_landmarks
            << " points, " << before.line_landmarks << " lines; after the jump " << after.size()
            << " frames, relocalised " << relocalised << ", tracking " << tracking << std::endl;
  EXPECT_GE(relocalised, 1u) << "never relocalised in the kept map";
  EXPECT_GE(tracking, 10u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "lifecycle_test");
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Harness harness;
  h = &harness;
  if (!harness.feed.Open(nh, pnh, 1, 80, "lifecycle_test")) return 1;
  harness.status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 100, [&harness](const pl_slam::TrackingStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.statuses.push_back(*m);
      });
  harness.path_sub = nh.subscribe<nav_msgs::Path>(
      "/pl_slam/path", 100, [&harness](const nav_msgs::Path::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.paths.emplace_back(ros::WallTime::now(), *m);
      });
  harness.markers_sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "/pl_slam/markers", 100, [&harness](const visualization_msgs::MarkerArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.markers.emplace_back(ros::WallTime::now(), *m);
      });
  harness.rosout_sub = nh.subscribe<rosgraph_msgs::Log>(
      "/rosout", 100, [&harness](const rosgraph_msgs::Log::ConstPtr& m) {
        if (m->level < rosgraph_msgs::Log::WARN) return;
        std::lock_guard<std::mutex> lock(harness.mutex);
        harness.warnings.push_back(m->msg);
      });
  const bool connected = WaitFor(
      [&] {
        return harness.feed.Connected() && harness.status_sub.getNumPublishers() > 0 &&
               harness.rosout_sub.getNumPublishers() > 0;
      },
      60.0);
  if (!connected) {
    ROS_FATAL("lifecycle_test: the nodelet did not subscribe to the inputs within 60 s");
    return 1;
  }
  ros::WallDuration(1.0).sleep();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
