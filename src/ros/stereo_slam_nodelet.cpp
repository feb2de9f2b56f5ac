#include "pl_slam/ros/stereo_slam_nodelet.h"

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <boost/bind/bind.hpp>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/package.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include "pl_slam/TrackingStatus.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/map/map_io.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/ros/map_visualization.h"
#include "pl_slam/ros/stamp_policy.h"
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
  else if (!(input_warning_period >= 0.1 && input_warning_period <= 3600.0))
    os << "input_warning_period=" << input_warning_period << " must be in [0.1, 3600] s";
  else if (!(markers_rate >= 0.0 && markers_rate <= 100.0))
    os << "markers_rate=" << markers_rate << " must be in [0, 100] Hz (0 = no markers)";
  else if (!(map_cloud_segment_step >= 0.0 && map_cloud_segment_step <= 100.0))
    os << "map_cloud_segment_step=" << map_cloud_segment_step << " must be in [0, 100] m";
  else if (!(expected_rate >= 0.0 && expected_rate <= 1000.0))
    os << "expected_rate=" << expected_rate << " must be in [0, 1000] Hz (0 = from the stamps)";
  else if (!(debug_image_rate >= 0.0 && debug_image_rate <= 1000.0))
    os << "debug_image_rate=" << debug_image_rate
       << " must be in [0, 1000] Hz (0 = no debug image)";
  else if (!map_file.empty() && !system.mapping.enabled)
    os << "map_file='" << map_file << "' needs mapping.enabled=true (there is no map to load into)";
  else if (localization_only && !system.mapping.enabled)
    os << "localization_only=true needs mapping.enabled=true (there is no map to localise in)";
  else if (localization_only && map_file.empty())
    os << "localization_only=true needs map_file (a map saved with ~save_map): without one "
          "there is no map to localise in";
  else if (BackwardsStampPolicy p; !ParseBackwardsStampPolicy(backwards_stamp_policy, &p))
    os << "backwards_stamp_policy='" << backwards_stamp_policy
       << "' must be reset_after, reset or ignore";
  else if (!(backwards_stamp_reset_after > 0.0 && backwards_stamp_reset_after <= 86400.0))
    os << "backwards_stamp_reset_after=" << backwards_stamp_reset_after
       << " must be in (0, 86400] s";
  else if (!use_camera_info && !camera.Validate().empty())
    os << "camera.*: " << camera.Validate()
       << " (use_camera_info is false, so camera.fx, camera.fy, camera.cx, camera.cy, "
          "camera.baseline, camera.doffs, camera.width and camera.height must describe the "
          "rectified pair)";
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

}  // namespace

StereoSlamNodelet::~StereoSlamNodelet() {
  // Inputs first: no callback may post into the mailbox once teardown has started (the
  // subscribers are declared before the mailbox, so they would otherwise outlive it).
  input_stop_ = true;
  if (input_thread_.joinable()) input_thread_.join();
  input_check_timer_.stop();
  diagnostics_timer_.stop();
  exact_sync_.reset();
  approx_sync_.reset();
  exact_images_sync_.reset();
  approx_images_sync_.reset();
  left_sub_.unsubscribe();
  right_sub_.unsubscribe();
  left_info_sub_.unsubscribe();
  right_info_sub_.unsubscribe();
  input_queue_.disable();
  input_queue_.clear();
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
  table.Add("queue_size", &o->queue_size,
            "subscriber and synchroniser queue length per input (the worker keeps only the "
            "newest pair)");
  table.Add("use_camera_info", &o->use_camera_info,
            "calibration from the camera_info topics (raw images rectified from K, D, R, P); "
            "false = from camera.*");
  table.Add("images_rectified", &o->images_rectified,
            "images are rectified already whatever camera_info's D and R say (no remap)");
  table.Add("camera.fx", &o->camera.fx, "rectified focal length x, px (use_camera_info false)");
  table.Add("camera.fy", &o->camera.fy, "rectified focal length y, px (use_camera_info false)");
  table.Add("camera.cx", &o->camera.cx, "rectified principal point x, px (use_camera_info false)");
  table.Add("camera.cy", &o->camera.cy, "rectified principal point y, px (use_camera_info false)");
  table.Add("camera.baseline", &o->camera.baseline,
            "stereo baseline, m, right camera on the left's +x (use_camera_info false)");
  table.Add("camera.doffs", &o->camera.doffs,
            "right principal point x minus the left one's, px (use_camera_info false)");
  table.Add("camera.width", &o->camera.width, "image width, px (use_camera_info false)");
  table.Add("camera.height", &o->camera.height, "image height, px (use_camera_info false)");
  table.Add("input_warning_period", &o->input_warning_period,
            "seconds between warnings about the same kind of bad input");
  table.Add("markers_rate", &o->markers_rate,
            "highest rate of ~markers and the keyframe ~path, Hz, each sent when the map "
            "changed (0 = never)");
  table.Add("map_cloud_segment_step", &o->map_cloud_segment_step,
            "~map_cloud samples every 3D segment every this many m (0 = map points only)");
  table.Add("expected_rate", &o->expected_rate,
            "input rate the diagnostics expect, Hz (0 = from the image stamps)");
  table.Add("debug_image_rate", &o->debug_image_rate,
            "highest rate of ~debug_image, Hz, drawn only while subscribed (0 = never)");
  table.Add("map_file", &o->map_file,
            "map file (~save_map) loaded at start-up, the first frames relocalise in it; "
            "empty = a new map");
  table.Add("localization_only", &o->localization_only,
            "start in localisation-only mode: track and relocalise in the map, add no keyframe "
            "(needs map_file)");
  table.Add("backwards_stamp_policy", &o->backwards_stamp_policy,
            "an image stamp older than the previous one: reset_after (restart when it jumps "
            "back more than backwards_stamp_reset_after, else skip the frame), reset (always "
            "restart) or ignore (always skip); a restart keeps the map in localisation-only mode");
  table.Add("backwards_stamp_reset_after", &o->backwards_stamp_reset_after,
            "seconds a stamp must jump back to restart under reset_after (smaller: jitter, the "
            "frame is skipped)");
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
  // The vocabulary: the package's by default, relative paths relative to the package (as
  // the offline runner does with its build-time package folder).
  std::string& vocabulary = options_.system.loop.vocabulary;
  if (vocabulary.empty() || vocabulary[0] != '/') {
    const std::string package_dir = ros::package::getPath("pl_slam");
    if (package_dir.empty()) {
      NODELET_FATAL(
          "pl_slam: loop.vocabulary='%s' is relative to the package, but rospack cannot find "
          "the pl_slam package; give an absolute path; refusing to start",
          vocabulary.c_str());
      return false;
    }
    vocabulary = package_dir + "/" + (vocabulary.empty() ? "vocabulary" : vocabulary);
  }
  const LoopClosingOptions& loop = options_.system.loop;
  if (options_.system.mapping.enabled && (loop.enabled || loop.relocalize) &&
      !std::filesystem::exists(loop.vocabulary)) {
    NODELET_FATAL(
        "pl_slam: loop.vocabulary='%s' does not exist (loop closing or relocalisation is on); "
        "refusing to start",
        loop.vocabulary.c_str());
    return false;
  }
  if (!options_.map_file.empty()) {
    // A save of this file killed mid-write (kill -9) left its temporary file next to it.
    const int stale = RemoveStaleTemporaryFiles(options_.map_file);
    if (stale > 0)
      NODELET_INFO("pl_slam: removed %d stale temporary file(s) of an interrupted save of %s",
                   stale, options_.map_file.c_str());
    // Checked completely now (format, checksum, consistency) so a bad file stops the nodelet
    // at start-up; the core loads it again once the calibration is known.
    try {
      Map probe;
      pl_slam::LoadMap(options_.map_file, &probe);
      const MapCounts counts = probe.counts();
      NODELET_INFO("pl_slam: map_file %s: %zu keyframes, %zu points, %zu lines",
                   options_.map_file.c_str(), counts.keyframes, counts.points, counts.lines);
    } catch (const std::exception& e) {
      NODELET_FATAL("pl_slam: map_file='%s' cannot be loaded: %s; refusing to start",
                    options_.map_file.c_str(), e.what());
      return false;
    }
  }
  NODELET_INFO("pl_slam: effective configuration:\n%s", table.Describe().c_str());
  return true;
}

void StereoSlamNodelet::onInit() {
  InstallRosLogSink();
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  if (!LoadOptions(pnh)) {
    // Refuse to run misconfigured, and say so to the process supervisor: the exception makes
    // nodelet::Loader::load fail, so `nodelet load` and stereo_slam_node exit non-zero and
    // roslaunch reports the death (required="true" then stops the launch). A nodelet manager
    // hosting other nodelets keeps running; LoadOptions logged the one-line reason.
    throw std::runtime_error("pl_slam: refused to start (see the FATAL message above)");
  }
  accounting_ = std::make_unique<InputAccounting>(options_.approximate_sync
                                                      ? InputAccounting::Policy::kApproximate
                                                      : InputAccounting::Policy::kExact,
                                                  static_cast<size_t>(options_.queue_size));

  odom_pub_ = pnh.advertise<nav_msgs::Odometry>("odom", 10);
  pose_pub_ = pnh.advertise<geometry_msgs::PoseStamped>("pose", 10);
  path_pub_ = pnh.advertise<nav_msgs::Path>("path", 1, true);
  status_pub_ = pnh.advertise<pl_slam::TrackingStatus>("status", 10);
  markers_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  map_cloud_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
  keyframe_poses_pub_ = pnh.advertise<geometry_msgs::PoseArray>("keyframe_poses", 1, true);
  private_it_ = std::make_unique<image_transport::ImageTransport>(pnh);
  debug_pub_ = private_it_->advertise("debug_image", 1);
  localization_only_ = options_.localization_only;
  save_srv_ = pnh.advertiseService("save_trajectory", &StereoSlamNodelet::OnSaveTrajectory, this);
  save_map_srv_ = pnh.advertiseService("save_map", &StereoSlamNodelet::OnSaveMap, this);
  localization_srv_ = pnh.advertiseService("set_localization_only",
                                           &StereoSlamNodelet::OnSetLocalizationOnly, this);
  reset_srv_ = pnh.advertiseService("reset", &StereoSlamNodelet::OnReset, this);
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  tf_broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh);
  diagnostics_->setHardwareID("pl_slam");
  diagnostics_->add("input", this, &StereoSlamNodelet::DiagnoseInput);
  diagnostics_->add("tracking", this, &StereoSlamNodelet::DiagnoseTracking);
  diagnostics_timer_ = pnh.createWallTimer(
      ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });

  worker_ = std::thread(&StereoSlamNodelet::WorkerLoop, this);

  const int q = options_.queue_size;
  ros::NodeHandle input_nh(nh);
  input_nh.setCallbackQueue(&input_queue_);
  it_ = std::make_unique<image_transport::ImageTransport>(input_nh);
  left_sub_.subscribe(*it_, "left/image", q,
                      image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  right_sub_.subscribe(*it_, "right/image", q,
                       image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  // Each message is counted before the synchroniser sees it (OnImage, OnCameraInfo), so every
  // image is accounted for and CheckInputs can tell why no pair forms.
  left_sub_.registerCallback(
      [this](const sensor_msgs::ImageConstPtr& m) { OnImage(InputAccounting::kLeft, m); });
  right_sub_.registerCallback(
      [this](const sensor_msgs::ImageConstPtr& m) { OnImage(InputAccounting::kRight, m); });
  using boost::placeholders::_1;
  using boost::placeholders::_2;
  using boost::placeholders::_3;
  using boost::placeholders::_4;
  if (options_.use_camera_info) {
    left_info_sub_.subscribe(input_nh, "left/camera_info", q);
    right_info_sub_.subscribe(input_nh, "right/camera_info", q);
    left_info_sub_.registerCallback([this](const sensor_msgs::CameraInfoConstPtr& m) {
      OnCameraInfo(InputAccounting::kLeft, m);
    });
    right_info_sub_.registerCallback([this](const sensor_msgs::CameraInfoConstPtr& m) {
      OnCameraInfo(InputAccounting::kRight, m);
    });
    if (options_.approximate_sync) {
      approx_sync_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy>>(ApproxPolicy(q));
      approx_sync_->setMaxIntervalDuration(ros::Duration(options_.sync_tolerance));
      approx_sync_->registerCallback(
          boost::bind(&StereoSlamNodelet::StereoCallback, this, _1, _2, _3, _4));
    } else {
      exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(ExactPolicy(q));
      exact_sync_->registerCallback(
          boost::bind(&StereoSlamNodelet::StereoCallback, this, _1, _2, _3, _4));
      exact_sync_->registerDropCallback(&StereoSlamNodelet::OnStereoDropped, this);
    }
    NODELET_INFO("pl_slam: waiting for %s, %s and their camera_info (%s, %s)",
                 left_sub_.getTopic().c_str(), right_sub_.getTopic().c_str(),
                 left_info_sub_.getTopic().c_str(), right_info_sub_.getTopic().c_str());
  } else {
    // Calibration from the parameters: the same rectifier type, built once from the rectified
    // camera_info pair that describes camera.* (no remap).
    sensor_msgs::CameraInfo left_info, right_info;
    StereoCameraToInfo(options_.camera, "", "", &left_info, &right_info);
    rectifier_ = std::make_shared<StereoInfoRectifier>(left_info, right_info);
    if (options_.approximate_sync) {
      approx_images_sync_ = std::make_unique<message_filters::Synchronizer<ApproxImagesPolicy>>(
          ApproxImagesPolicy(q));
      approx_images_sync_->setMaxIntervalDuration(ros::Duration(options_.sync_tolerance));
      approx_images_sync_->registerCallback(
          boost::bind(&StereoSlamNodelet::ImagesCallback, this, _1, _2));
    } else {
      exact_images_sync_ =
          std::make_unique<message_filters::Synchronizer<ExactImagesPolicy>>(ExactImagesPolicy(q));
      exact_images_sync_->registerCallback(
          boost::bind(&StereoSlamNodelet::ImagesCallback, this, _1, _2));
      exact_images_sync_->registerDropCallback(&StereoSlamNodelet::OnImagesDropped, this);
    }
    NODELET_INFO("pl_slam: waiting for %s and %s; calibration from parameters: %s",
                 left_sub_.getTopic().c_str(), right_sub_.getTopic().c_str(),
                 rectifier_->Describe().c_str());
  }
  input_check_timer_ = pnh.createWallTimer(ros::WallDuration(options_.input_warning_period),
                                           &StereoSlamNodelet::CheckInputs, this);
  input_thread_ = std::thread([this] {
    while (!input_stop_) input_queue_.callAvailable(ros::WallDuration(0.05));
  });
}

void StereoSlamNodelet::ProcessOne(const StereoFrame& frame, const std_msgs::Header& header) {
  FrameResult result;
  try {
    result = system_->Process(frame);
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(5.0, "pl_slam: frame %d failed: %s", frame.index, e.what());
    accounting_->Rejected();
    return;
  }
  ++frames_processed_;
  accounting_->Processed();
  if (loops_rebase_) {
    loops_offset_ = result.loops;
    loops_rebase_ = false;
  }
  result.loops -= loops_offset_;
  if (result.loops <= 0) result.loop_correction_m = result.loop_correction_deg = 0.0;
  if (!T_base_cam_) {
    const std::string cam_frame =
        options_.camera_frame.empty() ? header.frame_id : options_.camera_frame;
    try {
      // Looked up once, at the first frame; a static mount published at start-up may need a
      // moment to reach the listener (frames arriving meanwhile are dropped, so keep it short).
      const auto tf = tf_buffer_->lookupTransform(options_.base_frame, cam_frame, ros::Time(0),
                                                  ros::Duration(0.2));
      const Eigen::Isometry3d T = tf2::transformToEigen(tf);
      T_base_cam_ = SE3(Eigen::Matrix3d(T.rotation()), Eigen::Vector3d(T.translation()));
      NODELET_INFO("pl_slam: camera mounting %s -> %s taken from TF", options_.base_frame.c_str(),
                   cam_frame.c_str());
    } catch (const tf2::TransformException&) {
      T_base_cam_ = SE3();
      NODELET_INFO("pl_slam: no TF %s -> %s; the camera frame is taken as the base frame",
                   options_.base_frame.c_str(), cam_frame.c_str());
    }
    // The mount is read once: stop listening, so /tf traffic costs nothing and our own
    // broadcasts after a bag loop (older stamps) raise no TF_OLD_DATA warnings here.
    tf_listener_.reset();
  }
  NoteForDiagnostics(frame, result);
  Publish(result, header);
  PublishMap(header);
  PublishDebugImage(frame, result, header);
}

void StereoSlamNodelet::StartSystemLocked(const StereoCamera& camera) {
  system_.reset();  // the old pipeline's threads stop before the new one starts
  auto system = std::make_unique<SlamSystem>(camera, options_.system);
  if (!options_.map_file.empty()) {
    system->LoadMap(options_.map_file);
    NODELET_INFO("pl_slam: map %s loaded; waiting to relocalise in it", options_.map_file.c_str());
  }
  system->SetLocalizationOnly(localization_only_);
  system_ = std::move(system);
  camera_ = camera;
  path_.poses.clear();
  keyframe_path_.poses.clear();
  current_pose_.reset();
  published_map_version_ = UINT64_MAX;
  last_stamp_ns_ = -1;
  loops_offset_ = 0;
  loops_rebase_ = false;
}

void StereoSlamNodelet::ResetSystemLocked() {
  path_.poses.clear();
  keyframe_path_.poses.clear();
  current_pose_.reset();
  published_map_version_ = UINT64_MAX;
  // A new map starts its count of frames, drops, refusals and loops.
  frames_processed_ = 0;
  accounting_->Restart();
  loops_rebase_ = true;
  PublishClearedMapLocked();
  if (!system_) return;
  system_->Reset();
  if (!options_.map_file.empty()) {
    try {
      system_->LoadMap(options_.map_file);
      NODELET_INFO("pl_slam: map %s loaded again after the reset", options_.map_file.c_str());
    } catch (const std::exception& e) {
      NODELET_ERROR("pl_slam: map_file='%s' cannot be loaded again: %s; mapping from scratch",
                    options_.map_file.c_str(), e.what());
    }
  }
}

void StereoSlamNodelet::RestartTrackingLocked() {
  path_.poses.clear();
  current_pose_.reset();
  published_map_version_ = UINT64_MAX;
  if (!system_) return;
  // SlamSystem has no "forget the pose, keep the map" call; LoadMap is exactly that for a map
  // in a file (tracking restarts and relocalises, the trajectory starts again), so the current
  // map goes through a private temporary file, unchanged.
  const std::string tmp = (std::filesystem::temp_directory_path() /
                           ("pl_slam_relocalise_" + std::to_string(::getpid()) + "_" +
                            std::to_string(reinterpret_cast<uintptr_t>(this)) + ".plmap"))
                              .string();
  try {
    system_->Flush();
    system_->SaveMap(tmp);
    system_->LoadMap(tmp);
  } catch (const std::exception& e) {
    NODELET_ERROR("pl_slam: cannot restart tracking in the current map (%s); keeping on", e.what());
  }
  std::error_code ignored;
  std::filesystem::remove(tmp, ignored);
}

void StereoSlamNodelet::PublishClearedMapLocked() {
  if (!path_pub_) return;  // not started
  nav_msgs::Path path;
  path.header.frame_id = options_.map_frame;
  path.header.stamp = ros::Time::now();
  path_pub_.publish(path);
  visualization_msgs::MarkerArray markers;
  markers.markers.emplace_back();
  markers.markers.back().header = path.header;
  markers.markers.back().action = visualization_msgs::Marker::DELETEALL;
  markers_pub_.publish(markers);
  sensor_msgs::PointCloud2 cloud =
      MakeMapCloud(MapSnapshot(), SE3(), options_.map_frame, path.header.stamp, 0.0);
  map_cloud_pub_.publish(cloud);
  geometry_msgs::PoseArray poses;
  poses.header = path.header;
  keyframe_poses_pub_.publish(poses);
}

}  // namespace ros_layer
}  // namespace pl_slam

PLUGINLIB_EXPORT_CLASS(pl_slam::ros_layer::StereoSlamNodelet, nodelet::Nodelet)
