// StereoSlamNodelet, output side: odometry, pose, TF, the map markers and path, the status
// message and the debug image.
#include <cstdio>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/TrackingStatus.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/ros/map_visualization.h"
#include "pl_slam/ros/stereo_slam_nodelet.h"

namespace pl_slam {
namespace ros_layer {

namespace {

geometry_msgs::TransformStamped ToTransformMsg(const SE3& T, const ros::Time& stamp,
                                               const std::string& parent,
                                               const std::string& child) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = parent;
  tf.child_frame_id = child;
  const geometry_msgs::Pose p = ToPoseMsg(T);
  tf.transform.translation.x = p.position.x;
  tf.transform.translation.y = p.position.y;
  tf.transform.translation.z = p.position.z;
  tf.transform.rotation = p.orientation;
  return tf;
}

}  // namespace

// Covariance over [position; rotation about the frame's axes] of a pose P expressed through
// the rigid change of frame T_bc: T_b = T_bc * P * T_bc^-1. `offset` is the base origin's
// position relative to the camera, rotated into P's frame: R_P * t_cb.
Matrix6d ToBaseFrame(const Matrix6d& cov, const SE3& T_bc, const Eigen::Vector3d& offset) {
  const Eigen::Matrix3d R = T_bc.rotation();
  Matrix6d J = Matrix6d::Zero();
  J.block<3, 3>(0, 0) = R;
  J.block<3, 3>(0, 3) = -R * Hat(offset);
  J.block<3, 3>(3, 3) = R;
  return J * cov * J.transpose();
}

void StereoSlamNodelet::Publish(const FrameResult& result, const std_msgs::Header& header) {
  // The SLAM world is the first camera pose; express it so that the base starts at the
  // origin of map and odom: T_map_base = T_base_cam * T_w_c * T_cam_base, and likewise the
  // odometry chain T_odom_base from T_odom_c. map -> odom takes the map's corrections
  // (bundle adjustment, loop closure, relocalisation); odom -> base stays continuous (REP-105).
  const SE3& T_bc = *T_base_cam_;
  const SE3 T_map_base = T_bc * result.T_w_c * T_bc.inverse();
  const SE3 T_odom_base = T_bc * result.T_odom_c * T_bc.inverse();
  const ros::Time stamp = header.stamp;

  if (result.pose_valid) {
    nav_msgs::Odometry odom;
    odom.header.stamp = stamp;
    odom.header.frame_id = options_.odom_frame;
    odom.child_frame_id = options_.base_frame;
    odom.pose.pose = ToPoseMsg(T_odom_base);
    // Pose covariance: the odometry chain's, grown over the tracked motion (ROS order x y z
    // rx ry rz, odom frame).
    const Eigen::Vector3d offset = result.T_odom_c.rotation() * T_bc.inverse().translation();
    const Matrix6d pose_cov = ToBaseFrame(result.odom_covariance, T_bc, offset);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) odom.pose.covariance[r * 6 + c] = pose_cov(r, c);
    // Twist: this frame's tracked motion over the time since the last message, in the base
    // frame (nav_msgs: twist in child_frame_id), with the increment's covariance scaled.
    const double dt = last_odom_stamp_.isZero() ? 0.0 : (stamp - last_odom_stamp_).toSec();
    if (dt > 0.0) {
      const SE3 step_base = T_bc * result.T_prev_cur * T_bc.inverse();
      const Vector6d xi = step_base.Log();  // [rho; phi]
      odom.twist.twist.linear.x = xi(0) / dt;
      odom.twist.twist.linear.y = xi(1) / dt;
      odom.twist.twist.linear.z = xi(2) / dt;
      odom.twist.twist.angular.x = xi(3) / dt;
      odom.twist.twist.angular.y = xi(4) / dt;
      odom.twist.twist.angular.z = xi(5) / dt;
      const Matrix6d Ad = T_bc.Adjoint();
      const Matrix6d twist_cov = Ad * result.covariance * Ad.transpose() / (dt * dt);
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) odom.twist.covariance[r * 6 + c] = twist_cov(r, c);
    } else {
      // No time step yet: the twist is unknown, said so with a huge variance.
      for (int k = 0; k < 6; ++k) odom.twist.covariance[k * 6 + k] = 1e6;
    }
    last_odom_stamp_ = stamp;
    odom_pub_.publish(odom);

    geometry_msgs::PoseStamped pose;
    pose.header.stamp = stamp;
    pose.header.frame_id = options_.map_frame;
    pose.pose = ToPoseMsg(T_map_base);
    pose_pub_.publish(pose);
    path_.header = pose.header;
    path_.poses.push_back(pose);
    current_pose_ = pose;
    path_pose_pending_ = true;

    if (options_.publish_tf) {
      std::vector<geometry_msgs::TransformStamped> tfs;
      tfs.push_back(ToTransformMsg(T_map_base * T_odom_base.inverse(), stamp, options_.map_frame,
                                   options_.odom_frame));
      tfs.push_back(ToTransformMsg(T_odom_base, stamp, options_.odom_frame, options_.base_frame));
      tf_broadcaster_->sendTransform(tfs);
    }
  }

  pl_slam::TrackingStatus status;
  status.header.stamp = stamp;
  status.header.frame_id = options_.map_frame;
  status.state = static_cast<uint8_t>(result.state);
  status.state_name = TrackingStateName(result.state);
  // One snapshot, so the accounting identity holds within the message.
  const InputCounts counts = accounting_->counts();
  status.frame_index = counts.processed;
  status.frames_dropped = counts.dropped;
  status.frames_rejected = counts.rejected;
  status.left_received = counts.received[InputAccounting::kLeft];
  status.right_received = counts.received[InputAccounting::kRight];
  status.left_unpaired = counts.unpaired[InputAccounting::kLeft];
  status.right_unpaired = counts.unpaired[InputAccounting::kRight];
  status.left_waiting = counts.waiting[InputAccounting::kLeft];
  status.right_waiting = counts.waiting[InputAccounting::kRight];
  status.pairs_in_progress = counts.in_progress;
  status.points_detected = static_cast<uint32_t>(result.points_detected);
  status.lines_detected = static_cast<uint32_t>(result.lines_detected);
  status.point_inliers = static_cast<uint32_t>(result.point_inliers);
  status.line_inliers = static_cast<uint32_t>(result.line_inliers);
  status.keyframes = static_cast<uint32_t>(result.keyframes);
  status.point_landmarks = static_cast<uint32_t>(result.map_points);
  status.line_landmarks = static_cast<uint32_t>(result.map_lines);
  status.map_point_inliers = static_cast<uint32_t>(result.map_point_inliers);
  status.map_line_inliers = static_cast<uint32_t>(result.map_line_inliers);
  status.loops = static_cast<uint32_t>(result.loops);
  status.loop_correction_m = static_cast<float>(result.loop_correction_m);
  status.loop_correction_deg = static_cast<float>(result.loop_correction_deg);
  status.map_tracked = result.map_tracked;
  status.direct_aligned = result.direct_aligned;
  status.prior_fused = result.prior_fused;
  status.relocalized = result.relocalized;
  status.localization_only = system_->localization_only();
  for (const auto& [name, ms] : result.stage_ms) {
    status.stage_names.push_back(name);
    status.stage_ms.push_back(static_cast<float>(ms));
  }
  status.total_ms = static_cast<float>(result.total_ms);
  status_pub_.publish(status);
}

void StereoSlamNodelet::PublishMap(const std_msgs::Header& header) {
  if (options_.markers_rate <= 0.0) return;
  const ros::WallTime now = ros::WallTime::now();
  if (!last_map_publish_.isZero() &&
      (now - last_map_publish_).toSec() < 1.0 / options_.markers_rate)
    return;
  // The SLAM world is the first left camera's optical frame; map (= odom at the start) is the
  // base at the start, so p_map = T_base_cam * p_w (see Publish).
  const SE3& T_map_w = *T_base_cam_;
  const uint64_t version = system_->map().version();
  const bool map_changed = version != published_map_version_;
  if (!map_changed && !path_pose_pending_) return;
  last_map_publish_ = now;
  if (map_changed) {
    const MapSnapshot snapshot = system_->map().Snapshot();
    published_map_version_ = snapshot.version;
    markers_pub_.publish(MakeMapMarkers(snapshot, T_map_w, options_.map_frame, header.stamp));
    keyframe_path_ = MakeKeyframePath(snapshot, T_map_w, *T_base_cam_, options_.map_frame);
    // For downstream nodes, from the same snapshot: re-sent whenever bundle adjustment or a
    // loop correction changes the map.
    map_cloud_pub_.publish(MakeMapCloud(snapshot, T_map_w, options_.map_frame, header.stamp,
                                        options_.map_cloud_segment_step));
    keyframe_poses_pub_.publish(
        MakeKeyframePoses(snapshot, T_map_w, *T_base_cam_, options_.map_frame, header.stamp));
  }
  // The keyframe trajectory (moved by bundle adjustment and loop closure) plus the current
  // pose; without keyframes (mapping off, or not yet) the per-frame path.
  nav_msgs::Path path;
  if (keyframe_path_.poses.empty()) {
    path = path_;
  } else {
    path = keyframe_path_;
    if (current_pose_) path.poses.push_back(*current_pose_);
  }
  path.header.frame_id = options_.map_frame;
  path.header.stamp = header.stamp;
  path_pub_.publish(path);
  path_pose_pending_ = false;
}

void StereoSlamNodelet::PublishDebugImage(const StereoFrame& frame, const FrameResult& result,
                                          const std_msgs::Header& header) {
  if (options_.debug_image_rate <= 0.0 || debug_pub_.getNumSubscribers() == 0) return;
  const ros::WallTime now = ros::WallTime::now();
  if (!last_debug_image_.isZero() &&
      (now - last_debug_image_).toSec() < 1.0 / options_.debug_image_rate)
    return;
  last_debug_image_ = now;
  char text[256];
  std::snprintf(text, sizeof(text),
                "%s%s%s | pts %d/%d lines %d/%d | map %d kf %d pts %d lines | loops %d | %.1f ms",
                TrackingStateName(result.state), result.relocalized ? " (relocalised)" : "",
                system_->localization_only() ? " LOCALISATION" : "", result.point_inliers,
                result.points_detected, result.line_inliers, result.lines_detected,
                result.keyframes, result.map_points, result.map_lines, result.loops,
                result.total_ms);
  const cv::Mat image = DrawDebugImage(frame.left, system_->last_features(), text);
  sensor_msgs::ImagePtr msg = boost::make_shared<sensor_msgs::Image>();
  msg->header = header;
  msg->height = static_cast<uint32_t>(image.rows);
  msg->width = static_cast<uint32_t>(image.cols);
  msg->encoding = sensor_msgs::image_encodings::BGR8;
  msg->is_bigendian = 0;
  msg->step = static_cast<uint32_t>(image.cols * 3);
  msg->data.resize(static_cast<size_t>(msg->step) * image.rows);
  for (int r = 0; r < image.rows; ++r)
    std::copy(image.ptr<uint8_t>(r), image.ptr<uint8_t>(r) + msg->step,
              msg->data.begin() + static_cast<size_t>(r) * msg->step);
  debug_pub_.publish(msg);
}

}  // namespace ros_layer
}  // namespace pl_slam
