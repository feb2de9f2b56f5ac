// rostest node: plays nothing itself; watches the nodelet while rosbag play feeds it.
#include <filesystem>

#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

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

  size_t odom_count = 0, status_count = 0, tracking_count = 0;
  pl_slam::TrackingStatus last_status;
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/pl_slam/odom", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) {
        ++odom_count;
        for (double c : m->pose.covariance) EXPECT_TRUE(std::isfinite(c));
      });
  ros::Subscriber status_sub = nh.subscribe<pl_slam::TrackingStatus>(
      "/pl_slam/status", 1000, [&](const pl_slam::TrackingStatus::ConstPtr& m) {
        ++status_count;
        if (m->state == pl_slam::TrackingStatus::TRACKING) ++tracking_count;
        last_status = *m;
      });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);

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
    if (status_count >= frames) break;
    if (status_count > 0 && (ros::WallTime::now() - last_change).toSec() > 8.0) break;
    ros::WallDuration(0.01).sleep();
  }
  ros::Duration(0.5).sleep();
  ros::spinOnce();

  EXPECT_GE(status_count + last_status.frames_dropped, frames) << "status messages missing";
  EXPECT_GE(static_cast<double>(odom_count), 0.95 * frames)
      << "odometry for under 95% of the frames";
  EXPECT_GE(static_cast<double>(tracking_count), 0.95 * frames);
  EXPECT_EQ(last_status.state_name, "TRACKING");
  EXPECT_GT(last_status.points_detected, 100u);
  EXPECT_TRUE(tf_ok) << "no TF map -> base_link";

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
  EXPECT_GE(result.coverage.ratio, 0.95);
  EXPECT_LT(result.ate.translation.rmse, max_ate)
      << "ATE RMSE " << result.ate.translation.rmse << " m";
  std::cout << "[nodelet_pipeline] frames " << frames << ", status " << status_count
            << ", odometry " << odom_count << ", dropped " << last_status.frames_dropped
            << ", ATE RMSE " << result.ate.translation.rmse << " m, coverage "
            << result.coverage.ratio << std::endl;

  // A bad path is refused with a message, not a crash.
  save.request.path = "/nonexistent_dir_pl_slam/x.tum";
  ASSERT_TRUE(ros::service::call("/pl_slam/save_trajectory", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_FALSE(save.response.message.empty());

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
