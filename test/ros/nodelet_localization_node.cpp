// rostest node: save a map from the mapping nodelet, then localise in it with a second nodelet
// started with map_file and localization_only (see nodelet_localization.test).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "pl_slam/SaveMap.h"
#include "pl_slam/TrackingStatus.h"

namespace {

constexpr char kManager[] = "/pl_slam_manager";

bool LoadNodelet(const std::string& name) {
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = "pl_slam/StereoSlamNodelet";
  const std::map<std::string, std::string> remaps = {{"/left/image", "/cam0/image_raw"},
                                                     {"/right/image", "/cam1/image_raw"},
                                                     {"/left/camera_info", "/cam0/camera_info"},
                                                     {"/right/camera_info", "/cam1/camera_info"}};
  for (const auto& [from, to] : remaps) {
    load.request.remap_source_args.push_back(from);
    load.request.remap_target_args.push_back(to);
  }
  return ros::service::call(std::string(kManager) + "/load_nodelet", load) && load.response.success;
}

bool UnloadNodelet(const std::string& name) {
  nodelet::NodeletUnload unload;
  unload.request.name = name;
  return ros::service::call(std::string(kManager) + "/unload_nodelet", unload) &&
         unload.response.success;
}

TEST(NodeletLocalization, RelocalisesInASavedMap) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string bag_path;
  ASSERT_TRUE(pnh.getParam("bag", bag_path)) << "the test needs ~bag";

  // 1. The mapping run (rosbag play in the launch file): poses by stamp.
  std::map<uint64_t, geometry_msgs::Point> mapping_poses;
  pl_slam::TrackingStatus mapping_status;
  size_t mapping_count = 0;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseStamped>(
      "/pl_slam/pose", 1000, [&](const geometry_msgs::PoseStamped::ConstPtr& m) {
        mapping_poses[m->header.stamp.toNSec()] = m->pose.position;
      });
  ros::Subscriber status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&](const pl_slam::TrackingStatus::ConstPtr& m) {
        ++mapping_count;
        mapping_status = *m;
      });
  const ros::WallTime start = ros::WallTime::now();
  ros::WallTime last_change = start;
  size_t last_seen = 0;
  while (ros::ok() && (ros::WallTime::now() - start).toSec() < 60.0) {
    ros::spinOnce();
    if (mapping_count != last_seen) {
      last_seen = mapping_count;
      last_change = ros::WallTime::now();
    }
    if (mapping_count > 0 && (ros::WallTime::now() - last_change).toSec() > 5.0) break;
    ros::WallDuration(0.01).sleep();
  }
  ASSERT_GT(mapping_count, 60u) << "the mapping nodelet processed too few frames";
  ASSERT_GT(mapping_status.keyframes, 2u);

  // 2. Save its map, and stop it (it would otherwise process the replay too).
  const std::string map_path = (std::filesystem::temp_directory_path() /
                                ("pl_slam_loc_" + std::to_string(::getpid()) + ".plmap"))
                                   .string();
  pl_slam::SaveMap save;
  save.request.path = map_path;
  ASSERT_TRUE(ros::service::call("/pl_slam/save_map", save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  ASSERT_TRUE(UnloadNodelet("/pl_slam"));
  pose_sub.shutdown();
  status_sub.shutdown();

  // 3. A corrupted map_file: the nodelet refuses to start, so loading it fails (and a
  // `nodelet load` or stereo_slam_node process exits non-zero), and it offers no services.
  const std::string bad_path = map_path + ".bad";
  {
    std::ifstream in(map_path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    bytes.resize(bytes.size() / 2);  // truncated
    std::ofstream(bad_path, std::ios::binary) << bytes;
  }
  ros::param::set("/pl_slam_bad/map_file", bad_path);
  EXPECT_FALSE(LoadNodelet("/pl_slam_bad")) << "a nodelet with a truncated map_file loaded";
  EXPECT_FALSE(ros::service::waitForService("/pl_slam_bad/save_map", ros::Duration(2.0)))
      << "a nodelet with a truncated map_file started";
  UnloadNodelet("/pl_slam_bad");
  std::filesystem::remove(bad_path);

  // 4. The localisation nodelet, with the saved map.
  ros::param::set("/pl_slam_loc/map_file", map_path);
  ros::Publisher left_pub = nh.advertise<sensor_msgs::Image>("/cam0/image_raw", 5);
  ros::Publisher right_pub = nh.advertise<sensor_msgs::Image>("/cam1/image_raw", 5);
  ros::Publisher left_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam0/camera_info", 5);
  ros::Publisher right_info_pub = nh.advertise<sensor_msgs::CameraInfo>("/cam1/camera_info", 5);
  ASSERT_TRUE(LoadNodelet("/pl_slam_loc"));
  ASSERT_TRUE(ros::service::waitForService("/pl_slam_loc/save_map", ros::Duration(20.0)))
      << "the localisation nodelet did not start";
  size_t statuses = 0, relocalized = 0, tracking = 0, close = 0, compared = 0;
  uint32_t min_keyframes = UINT32_MAX, max_keyframes = 0;
  bool all_localization_only = true;
  double worst = 0.0;
  std::map<uint64_t, geometry_msgs::Point> loc_poses;
  ros::Subscriber loc_status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam_loc/status", 1000, [&](const pl_slam::TrackingStatus::ConstPtr& m) {
        ++statuses;
        if (m->relocalized) ++relocalized;
        if (m->state == pl_slam::TrackingStatus::TRACKING) ++tracking;
        all_localization_only = all_localization_only && m->localization_only;
        if (m->keyframes > 0) min_keyframes = std::min(min_keyframes, m->keyframes);
        max_keyframes = std::max(max_keyframes, m->keyframes);
      });
  ros::Subscriber loc_pose_sub = nh.subscribe<geometry_msgs::PoseStamped>(
      "/pl_slam_loc/pose", 1000, [&](const geometry_msgs::PoseStamped::ConstPtr& m) {
        loc_poses[m->header.stamp.toNSec()] = m->pose.position;
      });
  const ros::WallTime connect = ros::WallTime::now();
  while (ros::ok() && (ros::WallTime::now() - connect).toSec() < 10.0 &&
         (left_pub.getNumSubscribers() == 0 || right_pub.getNumSubscribers() == 0 ||
          left_info_pub.getNumSubscribers() == 0 || right_info_pub.getNumSubscribers() == 0 ||
          loc_status_sub.getNumPublishers() == 0)) {
    ros::WallDuration(0.05).sleep();
  }

  // 5. Replay the recording at half speed.
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery({"/cam0/image_raw", "/cam1/image_raw",
                                             "/cam0/camera_info", "/cam1/camera_info"}));
  ros::Time previous;
  for (const rosbag::MessageInstance& m : view) {
    if (!ros::ok()) break;
    if (!previous.isZero() && m.getTime() > previous)
      ros::WallDuration((m.getTime() - previous).toSec() * 2.0).sleep();
    previous = m.getTime();
    if (auto img = m.instantiate<sensor_msgs::Image>()) {
      (m.getTopic() == "/cam0/image_raw" ? left_pub : right_pub).publish(img);
    } else if (auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
      (m.getTopic() == "/cam0/camera_info" ? left_info_pub : right_info_pub).publish(info);
    }
    ros::spinOnce();
  }
  bag.close();
  const ros::WallTime end = ros::WallTime::now();
  while (ros::ok() && (ros::WallTime::now() - end).toSec() < 3.0) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  UnloadNodelet("/pl_slam_loc");
  std::filesystem::remove(map_path);

  // 6. It relocalised in the map, tracked, added nothing, and its poses are the mapping run's.
  for (const auto& [stamp, p] : loc_poses) {
    const auto it = mapping_poses.find(stamp);
    if (it == mapping_poses.end()) continue;
    const double d = std::hypot(p.x - it->second.x, p.y - it->second.y, p.z - it->second.z);
    worst = std::max(worst, d);
    ++compared;
    if (d < 0.10) ++close;
  }
  std::cout << "[nodelet_localization] map keyframes " << mapping_status.keyframes << ", statuses "
            << statuses << ", relocalised " << relocalized << ", tracking " << tracking
            << ", poses compared " << compared << ", within 0.10 m " << close << ", worst " << worst
            << " m" << std::endl;
  EXPECT_GT(statuses, 60u);
  EXPECT_GE(relocalized, 1u) << "never relocalised in the loaded map";
  EXPECT_GE(static_cast<double>(tracking), 0.8 * statuses);
  EXPECT_TRUE(all_localization_only);
  EXPECT_EQ(max_keyframes, min_keyframes) << "keyframes added in localisation mode";
  EXPECT_GE(max_keyframes + 2, mapping_status.keyframes) << "the loaded map lost keyframes";
  EXPECT_GT(compared, 40u);
  EXPECT_GE(static_cast<double>(close), 0.9 * compared)
      << "localisation poses differ from the mapping run's";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodelet_localization_test");
  ros::NodeHandle nh;  // keeps the node alive for the whole test
  return RUN_ALL_TESTS();
}
