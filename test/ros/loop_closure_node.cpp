// rostest node: a loop closure seen through the ROS interface. It renders the synthetic room
// walk (pl_slam::sim, SceneKind::kRoom, two laps) itself, frame by frame, and feeds the nodelet
// one stereo pair at a time (each sent after the previous one's status, so none is dropped),
// until a loop has closed and ~frames_after_loop more frames have been processed. Then it
// checks, against what the nodelet published:
//   - ~odom stays continuous across the loop closure (no step over 5x the median step near
//     it) while map -> odom on /tf takes the correction the status reports (REP-105);
//   - ~odom's pose covariance grows with the distance walked and falls back at the loop;
//   - ~map_cloud is the map (its point count is the status' point_landmarks once the map is
//     still) in map_frame (the room's floor and ceiling bound it), and the loop correction
//     moves the points it holds.
// A lap without a loop closure fails the first test with a message; the others fail too.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/SetBool.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "pl_slam/TrackingStatus.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "test_util/stereo_feed.h"

namespace {

using pl_slam::testing_util::WaitFor;

struct OdomSample {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double position_variance = 0.0;  // trace of the position block of the pose covariance
};

struct Cloud {
  int64_t stamp_ns = 0;
  std::string frame_id;
  std::size_t samples = 0;              // source 1: samples along 3D segments
  std::vector<Eigen::Vector3f> points;  // source 0: map points
};

struct Recording {
  std::mutex mutex;
  std::vector<pl_slam::TrackingStatus> statuses;  // in arrival order
  std::map<int64_t, OdomSample> odom;             // by stamp
  std::map<int64_t, Eigen::Isometry3d> map_odom;  // map -> odom on /tf, by stamp
  std::map<int64_t, Eigen::Vector3d> map_pose;    // ~pose (base in map), by stamp
  std::vector<Cloud> clouds;                      // in arrival order
  std::vector<int64_t> sent;                      // stamps of the pairs sent, in order
  int64_t loop_stamp_ns = -1;                     // first frame whose status counts a loop
  std::size_t loop_frame = 0;                     // its position in `sent`
  bool map_still = false;                         // the cloud matched the status at the end
};

Recording* rec = nullptr;

std::size_t StatusCount() {
  std::lock_guard<std::mutex> lock(rec->mutex);
  return rec->statuses.size();
}

pl_slam::TrackingStatus LastStatus() {
  std::lock_guard<std::mutex> lock(rec->mutex);
  return rec->statuses.empty() ? pl_slam::TrackingStatus() : rec->statuses.back();
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Fraction of `a`'s points that `b` holds within `tol` metres (a point the map left alone).
double UnmovedFraction(const std::vector<Eigen::Vector3f>& a, std::vector<Eigen::Vector3f> b,
                       float tol) {
  if (a.empty()) return 0.0;
  std::sort(b.begin(), b.end(), [](const auto& p, const auto& q) { return p.x() < q.x(); });
  std::size_t kept = 0;
  for (const Eigen::Vector3f& p : a) {
    auto it = std::lower_bound(b.begin(), b.end(), p.x() - tol,
                               [](const Eigen::Vector3f& q, float x) { return q.x() < x; });
    for (; it != b.end() && it->x() <= p.x() + tol; ++it) {
      if ((*it - p).norm() <= tol) {
        ++kept;
        break;
      }
    }
  }
  return static_cast<double>(kept) / static_cast<double>(a.size());
}

double AngleOf(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

bool LoopFound() { return rec->loop_stamp_ns >= 0; }

#define REQUIRE_LOOP() \
  ASSERT_TRUE(LoopFound()) << "no loop closed in the run (see ALoopClosesOnTheRoomWalk)"

struct Feeder {
  pl_slam::testing_util::StereoFeed feed;
  std::unique_ptr<pl_slam::sim::SyntheticSequence> sequence;
  int frames_after_loop = 40;
  int settle_frames = 40;
};

Feeder* feeder = nullptr;

/// Publishes `frame` and waits for its status.
bool SendAndWait(const pl_slam::StereoFrame& frame) {
  const std::size_t before = StatusCount();
  ros::Time stamp;
  stamp.fromNSec(static_cast<uint64_t>(frame.stamp_ns));
  {
    std::lock_guard<std::mutex> lock(rec->mutex);
    rec->sent.push_back(frame.stamp_ns);
  }
  feeder->feed.Publish(frame.left, frame.right, stamp);
  return WaitFor([&] { return StatusCount() > before; }, 60.0);
}

TEST(LoopClosure, ALoopClosesOnTheRoomWalk) {
  const pl_slam::sim::SyntheticSequence& seq = *feeder->sequence;
  const int n = static_cast<int>(seq.size());
  const ros::WallTime start = ros::WallTime::now();
  int stop_at = n;  // after the loop: frames_after_loop more
  int k = 0;
  // Renders frame k + 1 while the nodelet processes frame k.
  std::future<pl_slam::StereoFrame> next =
      std::async(std::launch::async, [&seq] { return seq.Render(0); });
  for (; k < stop_at; ++k) {
    const pl_slam::StereoFrame frame = next.get();
    if (k + 1 < n) next = std::async(std::launch::async, [&seq, k] { return seq.Render(k + 1); });
    ASSERT_TRUE(SendAndWait(frame)) << "no status for frame " << k << " within 60 s";
    const pl_slam::TrackingStatus s = LastStatus();
    if (!LoopFound() && s.loops >= 1) {
      rec->loop_stamp_ns = frame.stamp_ns;
      rec->loop_frame = static_cast<std::size_t>(k);
      stop_at = std::min(n, k + 1 + feeder->frames_after_loop);
      std::cout << "[loop_closure] loop closed at frame " << k << " ("
                << (ros::WallTime::now() - start).toSec() << " s in)" << std::endl;
    }
  }
  if (next.valid()) next.wait();
  const pl_slam::TrackingStatus last = LastStatus();
  std::cout << "[loop_closure] " << k << " frames sent in "
            << (ros::WallTime::now() - start).toSec() << " s; last status: frame_index "
            << last.frame_index << ", dropped " << last.frames_dropped << ", keyframes "
            << last.keyframes << ", points " << last.point_landmarks << ", loops " << last.loops
            << std::endl;
  EXPECT_EQ(last.frames_dropped, 0u) << "frames were dropped although each waited its status";
  EXPECT_EQ(last.frame_index, static_cast<uint32_t>(k));
  ASSERT_TRUE(LoopFound()) << "no loop closed in " << k << " frames of the room walk ("
                           << seq.options().loops
                           << " laps; the offline runner closes one near frame 420 of the first)";
  EXPECT_LT(rec->loop_frame + static_cast<std::size_t>(feeder->frames_after_loop),
            static_cast<std::size_t>(n))
      << "the walk ended before frames_after_loop frames followed the loop";

  // Localisation only: no new keyframes, so the map comes to rest (global bundle adjustment
  // merged) and the latched cloud can be compared with the status' map size.
  std_srvs::SetBool loc;
  loc.request.data = true;
  ASSERT_TRUE(ros::service::call("/pl_slam/set_localization_only", loc));
  ASSERT_TRUE(loc.response.success) << loc.response.message;
  int matched_in_a_row = 0;
  for (int i = 0; i < feeder->settle_frames && k < n && matched_in_a_row < 3; ++i, ++k) {
    ASSERT_TRUE(SendAndWait(seq.Render(k))) << "no status for frame " << k;
    ros::WallDuration(0.2).sleep();  // the cloud of this frame, if the map changed
    std::lock_guard<std::mutex> lock(rec->mutex);
    const bool match = !rec->clouds.empty() &&
                       rec->clouds.back().points.size() == rec->statuses.back().point_landmarks;
    matched_in_a_row = match ? matched_in_a_row + 1 : 0;
  }
  rec->map_still = matched_in_a_row >= 3;
  ros::WallDuration(0.5).sleep();  // the last odom and /tf messages
}

TEST(LoopClosure, OdomStaysContinuousAndMapToOdomTakesTheCorrection) {
  REQUIRE_LOOP();
  std::lock_guard<std::mutex> lock(rec->mutex);
  const std::vector<int64_t>& sent = rec->sent;
  auto odom = [&](std::size_t i) {
    const auto it = rec->odom.find(sent[i]);
    EXPECT_TRUE(it != rec->odom.end()) << "no ~odom for frame " << i;
    return it == rec->odom.end() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : it->second.position;
  };
  auto map_odom = [&](std::size_t i) {
    const auto it = rec->map_odom.find(sent[i]);
    EXPECT_TRUE(it != rec->map_odom.end()) << "no map -> odom on /tf for frame " << i;
    return it == rec->map_odom.end() ? Eigen::Isometry3d::Identity() : it->second;
  };
  // Odom steps between consecutive frames (every frame of the run had a pose).
  std::vector<double> steps(sent.size(), 0.0);
  for (std::size_t i = 1; i < sent.size(); ++i) steps[i] = (odom(i) - odom(i - 1)).norm();
  const double median = Median(std::vector<double>(steps.begin() + 1, steps.end()));
  ASSERT_GT(median, 0.005) << "odom hardly moves: the walk is ~3 cm a frame";
  // The status counts the loop at frame L; the correction reaches the pose there or at the
  // next frame (the mapping thread applies it while frames are tracked).
  const std::size_t L = rec->loop_frame;
  ASSERT_GE(L, 20u);
  const std::size_t lo = L - 5, hi = std::min(sent.size() - 2, L + 5);
  double max_step = 0.0, max_jerk = 0.0;
  for (std::size_t i = lo; i <= hi; ++i) {
    max_step = std::max(max_step, steps[i]);
    max_jerk = std::max(max_jerk, (odom(i + 1) - 2 * odom(i) + odom(i - 1)).norm());
  }
  std::vector<double> jerks;  // second differences before the loop, for the report
  for (std::size_t i = 1; i + 10 < L; ++i)
    jerks.push_back((odom(i + 1) - 2 * odom(i) + odom(i - 1)).norm());
  // map -> odom across the loop, as the move of the camera's map position it implies (the
  // camera held at its odom position at the loop), and its frame-to-frame changes before it:
  // bundle adjustment moving the anchor keyframe moves it a little now and then.
  const Eigen::Isometry3d before = map_odom(L - 3),
                          after = map_odom(std::min(sent.size() - 1, L + 3));
  const double jump = (after * odom(L) - before * odom(L)).norm();
  const double jump_deg = AngleOf(before.rotation().transpose() * after.rotation()) * 180 / M_PI;
  std::vector<double> changes;
  for (std::size_t i = 1; i + 10 < L; ++i)
    changes.push_back((map_odom(i) * odom(i) - map_odom(i - 1) * odom(i)).norm());
  std::sort(changes.begin(), changes.end());
  const double usual_change = changes.empty() ? 0.0 : changes[changes.size() * 95 / 100];
  const double largest_change = changes.empty() ? 0.0 : changes.back();
  // What the loop correction did to the newest keyframe, as the first status after it says.
  double reported = 0.0, reported_deg = 0.0;
  for (const pl_slam::TrackingStatus& s : rec->statuses) {
    if (s.loops < 1) continue;
    reported = s.loop_correction_m;
    reported_deg = s.loop_correction_deg;
    break;
  }
  std::cout << "[loop_closure] odom step median " << median * 100 << " cm, max within 5 frames "
            << "of the loop " << max_step * 100 << " cm (" << max_step / median
            << "x the median); odom second difference there " << max_jerk * 1000
            << " mm (before the loop: median " << Median(jerks) * 1000 << " mm); map -> odom "
            << "across the loop moves the camera " << jump * 1000 << " mm, " << jump_deg
            << " deg (frame-to-frame changes before it: 95th percentile " << usual_change * 1000
            << " mm, largest " << largest_change * 1000 << " mm); the status reports a loop "
            << "correction of " << reported * 1000 << " mm, " << reported_deg << " deg"
            << std::endl;
  EXPECT_LE(max_step, 5.0 * median) << "~odom jumps at the loop closure (REP-105: the odom "
                                       "frame is continuous; corrections go into map -> odom)";
  // A correction of ~1 cm hides in a 2.7 cm step, not in the second difference (~1 mm on a
  // smooth walk): part of a correction the mapping thread applied while a frame was tracked
  // showed there as 13-23 mm; the frame that takes the tracker's own increment instead of the
  // map-refined one gives up to ~5 mm.
  EXPECT_LE(max_jerk, 10.0 * Median(jerks))
      << "~odom's motion changes abruptly at the loop closure (a correction leaked into odom)";
  // map -> odom takes the correction: the camera's map position moves about as far as the
  // newest keyframe did. Measured 0.95-1.65x as far: the global bundle adjustment that follows
  // the correction often lands within the six frames compared. A correction that leaked into odom
  // leaves map -> odom where it was (on this walk it did so with the whole correction).
  EXPECT_GT(reported, 0.0) << "the status reports no loop correction";
  EXPECT_GT(jump, 0.5 * reported)
      << "map -> odom moved the camera much less than the loop correction moved the newest "
         "keyframe: the correction went elsewhere (into ~odom?)";
  EXPECT_LT(jump, 2.0 * reported + 2.0 * usual_change)
      << "map -> odom moved the camera much more than the loop correction moved the newest "
         "keyframe";
}

TEST(LoopClosure, OdomCovarianceGrowsWithDistanceAndFallsAtTheLoop) {
  REQUIRE_LOOP();
  std::lock_guard<std::mutex> lock(rec->mutex);
  const std::vector<int64_t>& sent = rec->sent;
  const std::size_t L = rec->loop_frame;
  auto var = [&](std::size_t i) {
    const auto it = rec->odom.find(sent[i]);
    return it == rec->odom.end() ? std::nan("") : it->second.position_variance;
  };
  const double q1 = var(L / 4), q2 = var(L / 2), q3 = var(3 * L / 4), before = var(L - 1),
               at = var(L), later = var(std::min(sent.size() - 1, L + 20));
  std::cout << "[loop_closure] odom position variance (trace, m^2): frame " << L / 4 << " " << q1
            << ", " << L / 2 << " " << q2 << ", " << 3 * L / 4 << " " << q3 << ", " << L - 1 << " "
            << before << "; at the loop " << at << ", 20 frames later " << later << std::endl;
  EXPECT_LT(q1, q2) << "odom covariance does not grow with distance";
  EXPECT_LT(q2, q3) << "odom covariance does not grow with distance";
  EXPECT_LT(q3, before) << "odom covariance does not grow with distance";
  EXPECT_LT(at, 0.1 * before) << "odom covariance not reset at the loop closure";
  EXPECT_LT(later, q2) << "odom covariance after the loop grows back faster than before it";
  // Elsewhere it never falls: only the loop ties the pose to the map again.
  for (std::size_t i = 1; i < L; ++i)
    EXPECT_GE(var(i), var(i - 1) * 0.999) << "odom covariance fell at frame " << i;
}

TEST(LoopClosure, MapCloudIsTheMapInTheMapFrameAndMovesAtTheLoop) {
  REQUIRE_LOOP();
  std::lock_guard<std::mutex> lock(rec->mutex);
  ASSERT_GE(rec->clouds.size(), 3u) << "~map_cloud was hardly sent";
  // Points left in place (within 1 mm) from one cloud to the next: local bundle adjustment
  // moves the points near the camera, a loop correction nearly all. The correction reaches the
  // map while a frame is tracked, so its cloud is one of the frames around the loop frame.
  const std::size_t L = rec->loop_frame;
  const int64_t window_start = rec->sent[L >= 3 ? L - 3 : 0],
                window_end = rec->sent[std::min(rec->sent.size() - 1, L + 3)],
                usual_end = rec->sent[L >= 10 ? L - 10 : 0];
  std::vector<double> usual;
  double at_loop = 1.0;
  std::size_t loop_cloud = 0;
  for (std::size_t i = 6; i < rec->clouds.size(); ++i) {
    const Cloud& c = rec->clouds[i];
    if (c.stamp_ns > window_end) break;
    if (c.stamp_ns >= window_start) {
      const double f = UnmovedFraction(rec->clouds[i - 1].points, c.points, 1e-3f);
      if (f < at_loop) at_loop = f, loop_cloud = i;
    } else if (c.stamp_ns < usual_end) {
      usual.push_back(UnmovedFraction(rec->clouds[i - 1].points, c.points, 1e-3f));
    }
  }
  ASSERT_GE(usual.size(), 10u) << "too few ~map_cloud messages before the loop";
  ASSERT_GT(loop_cloud, 0u) << "no ~map_cloud within 3 frames of the loop";
  const double usual_median = Median(usual);
  const double usual_min = *std::min_element(usual.begin(), usual.end());
  const Cloud& before = rec->clouds[loop_cloud - 1];
  const Cloud& after = rec->clouds[loop_cloud];
  const Cloud& last = rec->clouds.back();
  // The room: floor at z = 0 of map (the base is on the floor), ceiling at 3 m.
  std::vector<double> z;
  for (const auto& p : last.points) z.push_back(p.z());
  std::sort(z.begin(), z.end());
  const double z05 = z.empty() ? 0 : z[z.size() / 20], z95 = z.empty() ? 0 : z[z.size() * 19 / 20];
  const pl_slam::TrackingStatus& s = rec->statuses.back();
  std::cout << "[loop_closure] ~map_cloud: " << rec->clouds.size() << " sent; before the loop "
            << before.points.size() << " points + " << before.samples
            << " segment samples, after it " << after.points.size() << " + " << after.samples
            << "; points left in place from one cloud to the next: " << at_loop * 100
            << "% at the loop, before it median " << usual_median * 100 << "%, min "
            << usual_min * 100 << "%; last cloud " << last.points.size()
            << " points (status: " << s.point_landmarks << " point landmarks), z 5-95% " << z05
            << " .. " << z95 << " m" << std::endl;
  for (const Cloud& cl : rec->clouds) EXPECT_EQ(cl.frame_id, "map");
  EXPECT_TRUE(rec->map_still) << "the last ~map_cloud never matched the status' map size";
  EXPECT_EQ(last.points.size(), s.point_landmarks) << "~map_cloud is not the map";
  EXPECT_GT(last.samples, 0u) << "no segment samples in ~map_cloud";
  EXPECT_GT(z05, -0.3) << "~map_cloud below the room's floor: not in the map frame";
  EXPECT_LT(z95, 3.3) << "~map_cloud above the room's ceiling: not in the map frame";
  EXPECT_GT(z95 - z05, 1.5) << "~map_cloud is flat: not the room";
  EXPECT_LT(at_loop, 0.5 * usual_median)
      << "the loop correction did not move the points of ~map_cloud";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "loop_closure_test");
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Recording recording;
  rec = &recording;
  Feeder f;
  feeder = &f;
  pl_slam::sim::SequenceOptions options;
  options.scene = pl_slam::sim::SceneKind::kRoom;
  options.loops = pnh.param("laps", 2);
  options.start_time_s = 1000.0;
  f.frames_after_loop = pnh.param("frames_after_loop", 40);
  f.settle_frames = pnh.param("settle_frames", 40);
  f.sequence = std::make_unique<pl_slam::sim::SyntheticSequence>(options);
  f.feed.camera = f.sequence->camera();
  f.feed.left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 5);
  f.feed.right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 5);
  f.feed.left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 5);
  f.feed.right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 5);

  ros::Subscriber status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&recording](const pl_slam::TrackingStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(recording.mutex);
        recording.statuses.push_back(*m);
      });
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/pl_slam/odom", 1000, [&recording](const nav_msgs::Odometry::ConstPtr& m) {
        OdomSample s;
        s.position = {m->pose.pose.position.x, m->pose.pose.position.y, m->pose.pose.position.z};
        s.position_variance =
            m->pose.covariance[0] + m->pose.covariance[7] + m->pose.covariance[14];
        std::lock_guard<std::mutex> lock(recording.mutex);
        recording.odom[static_cast<int64_t>(m->header.stamp.toNSec())] = s;
      });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseStamped>(
      "/pl_slam/pose", 1000, [&recording](const geometry_msgs::PoseStamped::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(recording.mutex);
        recording.map_pose[static_cast<int64_t>(m->header.stamp.toNSec())] = {
            m->pose.position.x, m->pose.position.y, m->pose.position.z};
      });
  ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf", 1000, [&recording](const tf2_msgs::TFMessage::ConstPtr& m) {
        for (const auto& t : m->transforms) {
          if (t.header.frame_id != "map" || t.child_frame_id != "odom") continue;
          Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
          T.translation() << t.transform.translation.x, t.transform.translation.y,
              t.transform.translation.z;
          const auto& q = t.transform.rotation;
          T.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
          std::lock_guard<std::mutex> lock(recording.mutex);
          recording.map_odom[static_cast<int64_t>(t.header.stamp.toNSec())] = T;
        }
      });
  ros::Subscriber cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/pl_slam/map_cloud", 100, [&recording](const sensor_msgs::PointCloud2::ConstPtr& m) {
        Cloud c;
        c.stamp_ns = static_cast<int64_t>(m->header.stamp.toNSec());
        c.frame_id = m->header.frame_id;
        if (m->point_step == 16 && m->data.size() >= std::size_t{m->point_step} * m->width) {
          for (std::size_t i = 0; i < m->width; ++i) {
            const uint8_t* d = m->data.data() + i * m->point_step;
            float xyz[3];
            std::memcpy(xyz, d, sizeof(xyz));
            if (d[12] == 0) {
              c.points.emplace_back(xyz[0], xyz[1], xyz[2]);
            } else {
              ++c.samples;
            }
          }
        }
        std::lock_guard<std::mutex> lock(recording.mutex);
        recording.clouds.push_back(std::move(c));
      });
  // The camera mount (static TF) must be up before the first frame, which is when the
  // nodelet reads it.
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  const bool ready = WaitFor(
      [&] {
        return f.feed.Connected() && status_sub.getNumPublishers() > 0 &&
               cloud_sub.getNumPublishers() > 0 &&
               tf_buffer.canTransform("base_link", "cam0", ros::Time(0));
      },
      60.0);
  if (!ready) {
    ROS_FATAL(
        "loop_closure_test: the nodelet did not subscribe to the inputs (or no camera "
        "mount on /tf) within 60 s");
    return 1;
  }
  ros::WallDuration(1.0).sleep();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}
