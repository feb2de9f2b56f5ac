// rostest node: plays nothing itself; watches the nodelet while rosbag play feeds it.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <gtest/gtest.h>
#include <geometry_msgs/PoseArray.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "pl_slam/SaveMap.h"
#include "pl_slam/SaveTrajectory.h"
#include "pl_slam/TrackingStatus.h"
#include "pl_slam/eval/evaluation.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/ros/bag_io.h"

namespace {

TEST(NodeletPipeline, TracksSyntheticRecording) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string bag;
  ASSERT_TRUE(pnh.getParam("bag", bag)) << "the test needs ~bag";
  double max_ate = 0.10;
  pnh.getParam("max_ate", max_ate);

  pl_slam::ros_layer::BagStereoSource source(bag);
  const size_t frames = source.size();
  const pl_slam::Trajectory gt = source.ground_truth();
  ASSERT_GT(frames, 20u);
  ASSERT_EQ(gt.size(), frames);

  size_t odom_count = 0, status_count = 0, tracking_count = 0, twists_with_covariance = 0;
  double first_position_variance = -1.0, last_position_variance = -1.0, max_speed = 0.0;
  pl_slam::TrackingStatus last_status;
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/pl_slam/odom", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) {
        ++odom_count;
        for (double c : m->pose.covariance) EXPECT_TRUE(std::isfinite(c));
        for (double c : m->twist.covariance) EXPECT_TRUE(std::isfinite(c));
        const double position_variance =
            m->pose.covariance[0] + m->pose.covariance[7] + m->pose.covariance[14];
        if (odom_count == 1) first_position_variance = position_variance;
        last_position_variance = position_variance;
        const auto& v = m->twist.twist.linear;
        max_speed = std::max(max_speed, std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z));
        if (odom_count > 1 && m->twist.covariance[0] > 0.0 && m->twist.covariance[0] < 1.0)
          ++twists_with_covariance;
      });
  ros::Subscriber status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&](const pl_slam::TrackingStatus::ConstPtr& m) {
        ++status_count;
        if (m->state == pl_slam::TrackingStatus::TRACKING) ++tracking_count;
        last_status = *m;
      });
  visualization_msgs::MarkerArray markers;
  size_t marker_arrays = 0;
  ros::Subscriber markers_sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "/pl_slam/markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) {
        ++marker_arrays;
        markers = *m;
      });
  sensor_msgs::PointCloud2 cloud;
  size_t clouds = 0;
  ros::Subscriber cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/pl_slam/map_cloud", 10, [&](const sensor_msgs::PointCloud2::ConstPtr& m) {
        ++clouds;
        cloud = *m;
      });
  geometry_msgs::PoseArray keyframe_poses;
  ros::Subscriber keyframe_poses_sub = nh.subscribe<geometry_msgs::PoseArray>(
      "/pl_slam/keyframe_poses", 10,
      [&](const geometry_msgs::PoseArray::ConstPtr& m) { keyframe_poses = *m; });
  nav_msgs::Path path_msg;
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>(
      "/pl_slam/path", 10, [&](const nav_msgs::Path::ConstPtr& m) { path_msg = *m; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);

  // Localisation-only mode for a stretch in the middle of the recording: switched on and off
  // through the service, reported by the status, and no keyframe is added meanwhile.
  enum class Phase { kMapping, kLocalizing, kMappingAgain } phase = Phase::kMapping;
  size_t localizing_statuses = 0, mapping_again_statuses = 0;
  uint32_t kf_min_localizing = std::numeric_limits<uint32_t>::max(), kf_max_localizing = 0;
  auto set_localization = [&](bool on) {
    std_srvs::SetBool srv;
    srv.request.data = on;
    EXPECT_TRUE(ros::service::call("/pl_slam/set_localization_only", srv));
    EXPECT_TRUE(srv.response.success) << srv.response.message;
    // Statuses already queued may predate the switch.
    ros::Duration(0.05).sleep();
    ros::spinOnce();
  };
  ros::Subscriber mode_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&](const pl_slam::TrackingStatus::ConstPtr& m) {
        if (phase == Phase::kLocalizing && m->localization_only) {
          ++localizing_statuses;
          kf_min_localizing = std::min(kf_min_localizing, m->keyframes);
          kf_max_localizing = std::max(kf_max_localizing, m->keyframes);
        }
        if (phase == Phase::kMappingAgain && !m->localization_only) ++mapping_again_statuses;
      });

  // Wait until every frame was processed, or the stream went quiet after it started.
  const ros::WallTime start = ros::WallTime::now();
  ros::WallTime last_change = start;
  size_t last_seen = 0;
  bool tf_ok = false;
  while (ros::ok() && (ros::WallTime::now() - start).toSec() < 240.0) {
    ros::spinOnce();
    if (status_count != last_seen) {
      last_seen = status_count;
      last_change = ros::WallTime::now();
    }
    if (!tf_ok && status_count > 0)
      tf_ok = tf_buffer.canTransform("map", "base_link", ros::Time(0));
    if (phase == Phase::kMapping && status_count >= frames / 2) {
      set_localization(true);
      phase = Phase::kLocalizing;
    } else if (phase == Phase::kLocalizing && status_count >= frames * 3 / 4) {
      set_localization(false);
      phase = Phase::kMappingAgain;
    }
    if (status_count >= frames) break;
    if (status_count > 0 && (ros::WallTime::now() - last_change).toSec() > 8.0) break;
    ros::WallDuration(0.01).sleep();
  }
  ros::Duration(0.5).sleep();
  ros::spinOnce();

  // Every frame is accounted for: processed (one status each) or dropped because the worker
  // was still busy with an earlier one. Drops depend on the machine's load, not on the
  // pipeline (speed is the benchmark's to judge), so the checks below are per processed frame;
  // a worker that fell behind on most frames would leave too little to judge tracking by.
  const size_t dropped = last_status.frames_dropped;
  EXPECT_GE(status_count + dropped, frames) << "status messages missing";
  ASSERT_GE(2 * status_count, frames)
      << "the worker dropped " << dropped << " of " << frames
      << " frames: the machine is too loaded for this test to judge tracking";
  EXPECT_GE(static_cast<double>(odom_count), 0.95 * status_count)
      << "odometry for under 95% of the processed frames";
  EXPECT_GE(static_cast<double>(tracking_count), 0.95 * status_count);
  // ~odom: the first pose defines the frame (no uncertainty), the covariance grows with the
  // walk, and the twist carries the tracked motion (the demo walks at 0.4-0.65 m/s).
  EXPECT_LT(first_position_variance, 1e-6);
  EXPECT_GT(last_position_variance, 100.0 * std::max(first_position_variance, 1e-12));
  EXPECT_GT(max_speed, 0.2);
  EXPECT_LT(max_speed, 3.0);
  EXPECT_GE(static_cast<double>(twists_with_covariance), 0.9 * odom_count);
  EXPECT_EQ(last_status.state_name, "TRACKING");
  EXPECT_GT(last_status.points_detected, 100u);
  EXPECT_TRUE(tf_ok) << "no TF map -> base_link";
  EXPECT_GT(last_status.keyframes, 2u);
  EXPECT_GT(last_status.point_landmarks, 100u);
  EXPECT_GT(last_status.line_landmarks, 10u);
  EXPECT_FALSE(last_status.localization_only);

  // Localisation-only stretch.
  EXPECT_GT(localizing_statuses, 3u) << "no status reported localization_only after the switch";
  EXPECT_LE(kf_max_localizing, kf_min_localizing + 1)
      << "keyframes were added in localisation-only mode";
  EXPECT_GT(mapping_again_statuses, 3u) << "localization_only stayed on after switching it off";

  // Markers: the map's points and segments, in the map frame, around the path.
  EXPECT_GT(marker_arrays, 0u) << "no /pl_slam/markers";
  const visualization_msgs::Marker* points = nullptr;
  const visualization_msgs::Marker* lines = nullptr;
  for (const auto& m : markers.markers) {
    if (m.ns == "points") points = &m;
    if (m.ns == "lines") lines = &m;
  }
  ASSERT_NE(points, nullptr) << "no \"points\" marker";
  ASSERT_NE(lines, nullptr) << "no \"lines\" marker";
  EXPECT_EQ(points->type, visualization_msgs::Marker::POINTS);
  EXPECT_EQ(points->action, visualization_msgs::Marker::ADD);
  EXPECT_GT(points->points.size(), 100u);
  EXPECT_EQ(lines->type, visualization_msgs::Marker::LINE_LIST);
  EXPECT_GT(lines->points.size(), 20u);
  EXPECT_EQ(lines->points.size() % 2, 0u);
  EXPECT_EQ(points->header.frame_id, "map");
  // ~map_cloud: the map points of the markers' snapshot (source 0) then segment samples
  // (source 1), in the map frame; ~keyframe_poses: the keyframes of the same snapshot.
  EXPECT_GT(clouds, 1u) << "~map_cloud not re-sent as the map grew";
  EXPECT_EQ(cloud.header.frame_id, "map");
  ASSERT_EQ(cloud.point_step, 16u);
  ASSERT_EQ(cloud.data.size(), static_cast<size_t>(cloud.point_step) * cloud.width);
  size_t cloud_points = 0, cloud_samples = 0;
  for (size_t i = 0; i < cloud.width; ++i) {
    const uint8_t source = cloud.data[i * cloud.point_step + 12];
    cloud_points += source == 0;
    cloud_samples += source == 1;
  }
  EXPECT_EQ(cloud_points, points->points.size());
  EXPECT_GE(cloud_samples, lines->points.size());  // at least both endpoints per segment
  EXPECT_EQ(keyframe_poses.header.frame_id, "map");
  EXPECT_GT(keyframe_poses.poses.size(), 2u);
  ASSERT_GT(path_msg.poses.size(), 2u) << "no /pl_slam/path";
  EXPECT_EQ(path_msg.header.frame_id, "map");
  {
    // Most map points within a few metres of the path (a wrong frame or a missing camera
    // mount puts them metres away), and the path ends at the last published pose.
    size_t near = 0;
    for (const auto& p : points->points) {
      double best = 1e9;
      for (const auto& q : path_msg.poses) {
        const double dx = p.x - q.pose.position.x, dy = p.y - q.pose.position.y,
                     dz = p.z - q.pose.position.z;
        best = std::min(best, std::sqrt(dx * dx + dy * dy + dz * dz));
      }
      if (best < 6.0) ++near;
    }
    EXPECT_GT(static_cast<double>(near), 0.9 * points->points.size())
        << "map points far from the path";
  }

  // Save the trajectory through the service and score it against the bag's ground truth.
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("pl_slam_rostest_" + std::to_string(::getpid()) + ".tum"))
                               .string();
  pl_slam::SaveTrajectory save;
  save.request.path = path;
  save.request.format = "tum";
  ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  const pl_slam::Trajectory est = pl_slam::ReadTumTrajectory(path);
  std::filesystem::remove(path);
  EXPECT_EQ(est.size(), save.response.poses);
  std::vector<double> frame_times;
  for (const auto& p : gt) frame_times.push_back(p.t);
  const auto result = pl_slam::eval::EvaluateTrajectory(est, gt, frame_times);
  // A pose for (nearly) every processed frame; dropped frames have none.
  EXPECT_GE(static_cast<double>(result.coverage.covered), 0.95 * status_count)
      << "coverage " << result.coverage.ratio << " with " << dropped << " frames dropped";
  EXPECT_LT(result.ate.translation.rmse, max_ate)
      << "ATE RMSE " << result.ate.translation.rmse << " m";
  std::cout << "[nodelet_pipeline] frames " << frames << ", status " << status_count
            << ", odometry " << odom_count << ", dropped " << dropped << ", ATE RMSE "
            << result.ate.translation.rmse << " m, coverage " << result.coverage.ratio << std::endl;

  // A bad path is refused with a message, not a crash.
  save.request.path = "/nonexistent_dir_pl_slam/x.tum";
  ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_FALSE(save.response.message.empty());

  // The map through ~save_map; a bad path is refused.
  const std::string map_path = (std::filesystem::temp_directory_path() /
                                ("pl_slam_rostest_" + std::to_string(::getpid()) + ".plmap"))
                                   .string();
  pl_slam::SaveMap save_map;
  save_map.request.path = map_path;
  ASSERT_TRUE(ros::service::call("/pl_slam/save_map", save_map));
  EXPECT_TRUE(save_map.response.success) << save_map.response.message;
  EXPECT_TRUE(std::filesystem::exists(map_path));
  if (std::filesystem::exists(map_path)) EXPECT_GT(std::filesystem::file_size(map_path), 1000u);
  std::filesystem::remove(map_path);
  save_map.request.path = "/nonexistent_dir_pl_slam/x.plmap";
  ASSERT_TRUE(ros::service::call("/pl_slam/save_map", save_map));
  EXPECT_FALSE(save_map.response.success);
  EXPECT_FALSE(save_map.response.message.empty());

  // Reset clears the trajectory.
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call("/pl_slam/reset", reset));
  EXPECT_TRUE(reset.response.success);
  save.request.path = path;
  ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
  EXPECT_TRUE(save.response.success);
  EXPECT_EQ(save.response.poses, 0u);
  std::filesystem::remove(path);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodelet_pipeline_test");
  ros::NodeHandle nh;  // keeps the node alive for the whole test
  return RUN_ALL_TESTS();
}
