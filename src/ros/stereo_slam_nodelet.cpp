#include "pl_slam/ros/stereo_slam_nodelet.h"

#include <algorithm>
#include <iomanip>
#include <set>
#include <sstream>

#include <boost/bind/bind.hpp>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_eigen/tf2_eigen.h>

#include "pl_slam/TrackingStatus.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace ros_layer {

std::string NodeletOptions::Validate() const {
  std::ostringstream os;
  auto bad_frame = [](const std::string& f) {
    return f.empty() || f.find(' ') != std::string::npos;
  };
  if (bad_frame(map_frame))
    os << "map_frame='" << map_frame << "' must be a non-empty frame name";
  else if (bad_frame(odom_frame))
    os << "odom_frame='" << odom_frame << "' must be a non-empty frame name";
  else if (bad_frame(base_frame))
    os << "base_frame='" << base_frame << "' must be a non-empty frame name";
  else if (!(sync_tolerance > 0.0 && sync_tolerance <= 1.0))
    os << "sync_tolerance=" << sync_tolerance << " must be in (0, 1] s";
  else if (queue_size < 1 || queue_size > 100)
    os << "queue_size=" << queue_size << " must be in [1, 100]";
  else
    os << system.Validate();
  return os.str();
}

namespace {

// Route core log messages to rosconsole under the nodelet's logger name.
void InstallRosLogSink() {
  SetLogSink([](LogLevel level, const std::string& msg) {
    switch (level) {
      case LogLevel::kDebug:
        ROS_DEBUG_NAMED("pl_slam", "%s", msg.c_str());
        break;
      case LogLevel::kInfo:
        ROS_INFO_NAMED("pl_slam", "%s", msg.c_str());
        break;
      case LogLevel::kWarn:
        ROS_WARN_NAMED("pl_slam", "%s", msg.c_str());
        break;
      case LogLevel::kError:
        ROS_ERROR_NAMED("pl_slam", "%s", msg.c_str());
        break;
    }
  });
}

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

StereoSlamNodelet::~StereoSlamNodelet() {
  // Inputs first: no callback may post into the mailbox once teardown has started (the
  // subscribers are declared before the mailbox, so they would otherwise outlive it).
  exact_sync_.reset();
  approx_sync_.reset();
  left_sub_.unsubscribe();
  right_sub_.unsubscribe();
  left_info_sub_.unsubscribe();
  right_info_sub_.unsubscribe();
  stop_ = true;
  mailbox_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

OptionTable MakeNodeletOptionTable(NodeletOptions* o) {
  OptionTable table = MakeOptionTable(&o->system);
  table.Add("map_frame", &o->map_frame, "fixed world frame (REP-105)");
  table.Add("odom_frame", &o->odom_frame, "odometry frame (REP-105)");
  table.Add("base_frame", &o->base_frame, "robot body frame");
  table.Add("camera_frame", &o->camera_frame,
            "left optical frame; empty = the image header's frame_id");
  table.Add("publish_tf", &o->publish_tf, "broadcast map -> odom -> base_frame");
  table.Add("approximate_sync", &o->approximate_sync,
            "ApproximateTime instead of ExactTime synchronisation");
  table.Add("sync_tolerance", &o->sync_tolerance,
            "largest stamp difference with approximate sync, seconds");
  table.Add("queue_size", &o->queue_size, "subscriber and synchroniser queue length");
  return table;
}

namespace {

/// A parameter value as the text OptionTable parses; false for lists and maps.
bool ParamToText(const XmlRpc::XmlRpcValue& v, std::string* out) {
  std::ostringstream os;
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      os << (static_cast<bool>(const_cast<XmlRpc::XmlRpcValue&>(v)) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      os << static_cast<int>(const_cast<XmlRpc::XmlRpcValue&>(v));
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      os << std::setprecision(17) << static_cast<double>(const_cast<XmlRpc::XmlRpcValue&>(v));
      break;
    case XmlRpc::XmlRpcValue::TypeString:
      os << static_cast<std::string>(const_cast<XmlRpc::XmlRpcValue&>(v));
      break;
    default:
      return false;
  }
  *out = os.str();
  return true;
}

}  // namespace

bool StereoSlamNodelet::LoadOptions(ros::NodeHandle& pnh) {
  // Every parameter in the private namespace must be a known option: a misspelt key would
  // otherwise silently keep its default. Nested namespaces map to dotted keys
  // (~tracker/points/max_points -> tracker.points.max_points).
  const OptionTable table = MakeNodeletOptionTable(&options_);
  std::vector<std::string> names;
  ros::param::getParamNames(names);
  const std::string prefix = pnh.getNamespace() + "/";
  for (const std::string& n : names) {
    if (n.rfind(prefix, 0) != 0) continue;
    std::string key = n.substr(prefix.size());
    std::replace(key.begin(), key.end(), '/', '.');
    XmlRpc::XmlRpcValue value;
    std::string text;
    if (!pnh.getParam(n.substr(prefix.size()), value) || !ParamToText(value, &text)) {
      NODELET_FATAL("pl_slam: parameter %s must be a single value; refusing to start", n.c_str());
      return false;
    }
    try {
      table.Set(key, text);
    } catch (const ConfigError& e) {
      NODELET_FATAL(
          "pl_slam: parameter %s: %s (print the known keys with `pl_slam_offline "
          "--print-config`); refusing to start",
          n.c_str(), e.what());
      return false;
    }
  }
  const std::string err = options_.Validate();
  if (!err.empty()) {
    NODELET_FATAL("pl_slam: bad parameter %s; refusing to start", err.c_str());
    return false;
  }
  NODELET_INFO("pl_slam: effective configuration:\n%s", table.Describe().c_str());
  return true;
}

void StereoSlamNodelet::onInit() {
  InstallRosLogSink();
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  if (!LoadOptions(pnh)) {
    // Refuse to run misconfigured: no subscriptions, nothing published.
    return;
  }

  odom_pub_ = pnh.advertise<nav_msgs::Odometry>("odom", 10);
  pose_pub_ = pnh.advertise<geometry_msgs::PoseStamped>("pose", 10);
  path_pub_ = pnh.advertise<nav_msgs::Path>("path", 1, true);
  status_pub_ = pnh.advertise<pl_slam::TrackingStatus>("status", 10);
  save_srv_ = pnh.advertiseService("save_trajectory", &StereoSlamNodelet::OnSaveTrajectory, this);
  reset_srv_ = pnh.advertiseService("reset", &StereoSlamNodelet::OnReset, this);
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  tf_broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();

  worker_ = std::thread(&StereoSlamNodelet::WorkerLoop, this);

  it_ = std::make_unique<image_transport::ImageTransport>(nh);
  const int q = options_.queue_size;
  left_sub_.subscribe(*it_, "left/image", q,
                      image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  right_sub_.subscribe(*it_, "right/image", q,
                       image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  left_info_sub_.subscribe(nh, "left/camera_info", q);
  right_info_sub_.subscribe(nh, "right/camera_info", q);
  if (options_.approximate_sync) {
    approx_sync_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy>>(
        ApproxPolicy(q), left_sub_, left_info_sub_, right_sub_, right_info_sub_);
    approx_sync_->setMaxIntervalDuration(ros::Duration(options_.sync_tolerance));
    approx_sync_->registerCallback(boost::bind(&StereoSlamNodelet::StereoCallback, this,
                                               boost::placeholders::_1, boost::placeholders::_2,
                                               boost::placeholders::_3, boost::placeholders::_4));
  } else {
    exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
        ExactPolicy(q), left_sub_, left_info_sub_, right_sub_, right_info_sub_);
    exact_sync_->registerCallback(boost::bind(&StereoSlamNodelet::StereoCallback, this,
                                              boost::placeholders::_1, boost::placeholders::_2,
                                              boost::placeholders::_3, boost::placeholders::_4));
  }
  NODELET_INFO("pl_slam: waiting for %s, %s and their camera_info", left_sub_.getTopic().c_str(),
               right_sub_.getTopic().c_str());
}

void StereoSlamNodelet::StereoCallback(const sensor_msgs::ImageConstPtr& left,
                                       const sensor_msgs::CameraInfoConstPtr& left_info,
                                       const sensor_msgs::ImageConstPtr& right,
                                       const sensor_msgs::CameraInfoConstPtr& right_info) {
  Pending p;
  try {
    p.camera = StereoCameraFromInfo(*left_info, *right_info);
    p.frame.left = ImageToMono8(*left);
    p.frame.right = ImageToMono8(*right);
  } catch (const InputError& e) {
    NODELET_WARN_THROTTLE(5.0, "pl_slam: stereo pair at %.3f ignored: %s",
                          left->header.stamp.toSec(), e.what());
    return;
  }
  if (p.frame.left.size() != p.frame.right.size()) {
    NODELET_WARN_THROTTLE(5.0, "pl_slam: stereo pair ignored: left %dx%d and right %dx%d differ",
                          p.frame.left.cols, p.frame.left.rows, p.frame.right.cols,
                          p.frame.right.rows);
    return;
  }
  p.frame.stamp_ns = ToNanoseconds(left->header.stamp);
  p.header = left->header;
  {
    std::lock_guard<std::mutex> lock(mailbox_mutex_);
    if (mailbox_) ++dropped_;  // the worker is behind: the newest frame replaces the old one
    mailbox_ = std::move(p);
  }
  mailbox_cv_.notify_one();
}

void StereoSlamNodelet::WorkerLoop() {
  while (!stop_) {
    Pending p;
    {
      std::unique_lock<std::mutex> lock(mailbox_mutex_);
      mailbox_cv_.wait(lock, [this] { return stop_ || mailbox_.has_value(); });
      if (stop_) return;
      p = std::move(*mailbox_);
      mailbox_.reset();
    }
    std::lock_guard<std::mutex> lock(system_mutex_);
    if (!system_ || p.camera.width != camera_.width || p.camera.height != camera_.height ||
        std::abs(p.camera.fx - camera_.fx) > 1e-6 ||
        std::abs(p.camera.baseline - camera_.baseline) > 1e-9) {
      if (system_) NODELET_WARN("pl_slam: camera_info changed; starting a new map");
      try {
        system_ = std::make_unique<SlamSystem>(p.camera, options_.system);
      } catch (const std::exception& e) {
        NODELET_ERROR_THROTTLE(5.0, "pl_slam: cannot start the pipeline: %s", e.what());
        continue;
      }
      camera_ = p.camera;
      path_.poses.clear();
      last_stamp_ns_ = -1;
    }
    if (last_stamp_ns_ >= 0 && p.frame.stamp_ns <= last_stamp_ns_) {
      NODELET_WARN("pl_slam: image stamp went backwards (%.3f after %.3f, bag loop?); resetting",
                   p.frame.stamp_ns * 1e-9, last_stamp_ns_ * 1e-9);
      system_->Reset();
      path_.poses.clear();
    }
    last_stamp_ns_ = p.frame.stamp_ns;
    p.frame.index = static_cast<int>(frames_processed_);
    ProcessOne(p.frame, p.header);
  }
}

void StereoSlamNodelet::ProcessOne(const StereoFrame& frame, const std_msgs::Header& header) {
  FrameResult result;
  try {
    result = system_->Process(frame);
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(5.0, "pl_slam: frame %d failed: %s", frame.index, e.what());
    return;
  }
  ++frames_processed_;
  if (!T_base_cam_) {
    const std::string cam_frame =
        options_.camera_frame.empty() ? header.frame_id : options_.camera_frame;
    try {
      // Looked up once, at the first frame, without blocking the worker for long.
      const auto tf = tf_buffer_->lookupTransform(options_.base_frame, cam_frame, ros::Time(0),
                                                  ros::Duration(0.05));
      const Eigen::Isometry3d T = tf2::transformToEigen(tf);
      T_base_cam_ = SE3(Eigen::Matrix3d(T.rotation()), Eigen::Vector3d(T.translation()));
      NODELET_INFO("pl_slam: camera mounting %s -> %s taken from TF", options_.base_frame.c_str(),
                   cam_frame.c_str());
    } catch (const tf2::TransformException&) {
      T_base_cam_ = SE3();
      NODELET_INFO("pl_slam: no TF %s -> %s; the camera frame is taken as the base frame",
                   options_.base_frame.c_str(), cam_frame.c_str());
    }
  }
  Publish(result, header);
}

void StereoSlamNodelet::Publish(const FrameResult& result, const std_msgs::Header& header) {
  // The SLAM world is the first camera pose; express it so that the base starts at the
  // origin of odom: T_odom_base = T_base_cam * T_w_c * T_cam_base.
  const SE3& T_bc = *T_base_cam_;
  const SE3 T_odom_base = T_bc * result.T_w_c * T_bc.inverse();
  const ros::Time stamp = header.stamp;

  if (result.pose_valid) {
    nav_msgs::Odometry odom;
    odom.header.stamp = stamp;
    odom.header.frame_id = options_.odom_frame;
    odom.child_frame_id = options_.base_frame;
    odom.pose.pose = ToPoseMsg(T_odom_base);
    // Covariance of the increment expressed in the base frame (ROS order x y z rx ry rz).
    const Matrix6d Ad = T_bc.Adjoint();
    const Matrix6d cov = Ad * result.covariance * Ad.transpose();
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) odom.pose.covariance[r * 6 + c] = cov(r, c);
    odom_pub_.publish(odom);

    geometry_msgs::PoseStamped pose;
    pose.header.stamp = stamp;
    pose.header.frame_id = options_.map_frame;
    pose.pose = odom.pose.pose;
    pose_pub_.publish(pose);
    path_.header = pose.header;
    path_.poses.push_back(pose);
    if (path_pub_.getNumSubscribers() > 0 && (frames_processed_ % 5 == 0)) path_pub_.publish(path_);

    if (options_.publish_tf) {
      std::vector<geometry_msgs::TransformStamped> tfs;
      tfs.push_back(ToTransformMsg(SE3(), stamp, options_.map_frame, options_.odom_frame));
      tfs.push_back(ToTransformMsg(T_odom_base, stamp, options_.odom_frame, options_.base_frame));
      tf_broadcaster_->sendTransform(tfs);
    }
  }

  pl_slam::TrackingStatus status;
  status.header.stamp = stamp;
  status.header.frame_id = options_.map_frame;
  status.state = static_cast<uint8_t>(result.state);
  status.state_name = TrackingStateName(result.state);
  status.frame_index = frames_processed_;
  status.frames_dropped = dropped_.load();
  status.points_detected = static_cast<uint32_t>(result.points_detected);
  status.lines_detected = static_cast<uint32_t>(result.lines_detected);
  status.point_inliers = static_cast<uint32_t>(result.point_inliers);
  status.line_inliers = static_cast<uint32_t>(result.line_inliers);
  for (const auto& [name, ms] : result.stage_ms) {
    status.stage_names.push_back(name);
    status.stage_ms.push_back(static_cast<float>(ms));
  }
  status.total_ms = static_cast<float>(result.total_ms);
  status_pub_.publish(status);
}

bool StereoSlamNodelet::OnSaveTrajectory(pl_slam::SaveTrajectory::Request& req,
                                         pl_slam::SaveTrajectory::Response& res) {
  try {
    const TrajectoryFormat format =
        req.format.empty() ? TrajectoryFormat::kTum : ParseTrajectoryFormat(req.format);
    if (req.path.empty()) throw InputError("path is empty");
    Trajectory traj;
    uint32_t processed = 0;
    {
      std::lock_guard<std::mutex> lock(system_mutex_);
      if (system_) traj = system_->trajectory();
      processed = frames_processed_;
    }
    WriteTrajectory(req.path, traj, format);
    res.success = true;
    res.poses = static_cast<uint32_t>(traj.size());
    res.message = "wrote " + std::to_string(traj.size()) + " poses to " + req.path +
                  " (frames processed " + std::to_string(processed) + ", dropped " +
                  std::to_string(dropped_.load()) + ")";
    NODELET_INFO("pl_slam: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    NODELET_WARN("pl_slam: save_trajectory failed: %s", e.what());
  }
  return true;
}

bool StereoSlamNodelet::OnReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(system_mutex_);
  if (system_) system_->Reset();
  path_.poses.clear();
  last_stamp_ns_ = -1;
  res.success = true;
  res.message = "map and trajectory cleared";
  NODELET_INFO("pl_slam: reset");
  return true;
}

}  // namespace ros_layer
}  // namespace pl_slam

PLUGINLIB_EXPORT_CLASS(pl_slam::ros_layer::StereoSlamNodelet, nodelet::Nodelet)
