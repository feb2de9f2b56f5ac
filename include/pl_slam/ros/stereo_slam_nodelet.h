// The ROS face of pl_slam: converts messages, parameters and TF, and calls the core.
#pragma once

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nav_msgs/Path.h>
#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "pl_slam/SaveMap.h"
#include "pl_slam/SaveTrajectory.h"
#include "pl_slam/io/stereo_frame.h"
#include "pl_slam/ros/camera_info_rectifier.h"
#include "pl_slam/ros/input_accounting.h"
#include "pl_slam/system/slam_system.h"

namespace pl_slam {
namespace ros_layer {

/// Parameters of the nodelet (private namespace), validated at start-up.
struct NodeletOptions {
  std::string map_frame = "map";         ///< fixed world frame (REP-105)
  std::string odom_frame = "odom";       ///< odometry frame (REP-105)
  std::string base_frame = "base_link";  ///< robot body frame
  std::string camera_frame;              ///< left optical frame; empty = image header frame_id
  bool publish_tf = true;                ///< broadcast map->odom->base_link
  bool approximate_sync = false;         ///< ApproximateTime instead of ExactTime
  double sync_tolerance = 0.005;         ///< max stamp difference (s) with approximate sync
  /// Subscriber and synchroniser queue length. The subscribers run on their own thread that
  /// only counts, pairs and copies images, and the worker keeps just the newest pair, so this
  /// only has to absorb scheduling hiccups and the stamp lag between the two cameras: 30 is
  /// a second at 30 Hz. Images lost in roscpp's own queue (only if that thread stalls for this
  /// many images) never reach the nodelet and cannot be counted.
  int queue_size = 30;
  /// Calibration from the left/right camera_info topics (raw images are rectified from K, D,
  /// R, P); false = no camera_info subscription, calibration from the camera.* keys.
  bool use_camera_info = true;
  /// The images are rectified already whatever camera_info's D and R say (image_rect topics
  /// published with the raw camera_info): calibration from P only, no remap.
  bool images_rectified = false;
  /// "camera.*": rectified stereo calibration used when use_camera_info is false.
  StereoCamera camera;
  /// Seconds between two warnings about the same kind of bad input, and the period of the
  /// check for images that never form a synchronised pair.
  double input_warning_period = 5.0;
  /// Highest rate (Hz) of ~markers and of the keyframe ~path, each published only when the
  /// map changed (0 = never).
  double markers_rate = 2.0;
  /// Input rate (Hz) the diagnostics compare against: WARN below 3/4 of it. 0 = the rate the
  /// image stamps imply.
  double expected_rate = 0.0;
  /// ~map_cloud also samples every 3D segment every this many metres (0 = map points only).
  double map_cloud_segment_step = 0.05;
  /// Highest rate (Hz) of ~debug_image, drawn only while someone subscribes (0 = never).
  double debug_image_rate = 10.0;
  /// A map file (SaveMap) loaded at start-up; the first frames relocalise in it. Checked
  /// completely in onInit: a bad file stops the nodelet. Empty = start with an empty map.
  std::string map_file;
  /// Start in localisation-only mode (tracking and relocalisation, no new keyframes).
  bool localization_only = false;
  /// What an image stamp older than the previous frame's does (a looping bag, a restarted
  /// camera clock, out-of-order frames): "reset_after" restarts when it jumps back by more
  /// than backwards_stamp_reset_after s and skips the frame otherwise, "reset" restarts on
  /// every backwards stamp, "ignore" always skips the frame. A restart clears the map while
  /// mapping; in localisation-only mode it keeps the map and relocalises in it.
  std::string backwards_stamp_policy = "reset_after";
  /// Seconds a stamp must jump back to restart under "reset_after" (smaller jumps are jitter).
  double backwards_stamp_reset_after = 1.0;
  SystemOptions system;  ///< core pipeline options ("tracker.*" keys)

  /// Empty when valid, else "key=value must be ..." for the first bad field.
  std::string Validate() const;
};

/// The option table of the nodelet: its own keys plus every core key.
OptionTable MakeNodeletOptionTable(NodeletOptions* options);

/// Nodelet `pl_slam/StereoSlamNodelet`. Inputs: left/image, right/image (image_transport),
/// left/camera_info, right/camera_info (unless use_camera_info is false). Outputs (private
/// namespace): odom, pose, path, status, markers, debug_image, TF. Services: save_trajectory,
/// save_map, set_localization_only, reset.
///
/// Bad input never stops the nodelet: a pair with an unsupported encoding, sizes that differ
/// or an unusable camera_info is refused with a throttled warning (one per kind of problem
/// every input_warning_period s) and counted in status.frames_rejected; images that never
/// form a synchronised pair (no camera_info, stamps that differ) are reported as often. Every
/// image received is accounted for (InputAccounting, status.left_received ...). A stamp
/// older than the previous frame's is handled by backwards_stamp_policy (a restart keeps the map
/// in localisation-only mode); a repeated stamp is skipped.
class StereoSlamNodelet : public nodelet::Nodelet {
 public:
  StereoSlamNodelet() = default;
  ~StereoSlamNodelet() override;

 private:
  void onInit() override;
  bool LoadOptions(ros::NodeHandle& pnh);
  void StereoCallback(const sensor_msgs::ImageConstPtr& left,
                      const sensor_msgs::CameraInfoConstPtr& left_info,
                      const sensor_msgs::ImageConstPtr& right,
                      const sensor_msgs::CameraInfoConstPtr& right_info);
  void ImagesCallback(const sensor_msgs::ImageConstPtr& left,
                      const sensor_msgs::ImageConstPtr& right);
  /// Subscriber callbacks (input thread): count the message, then hand it to the synchroniser.
  void OnImage(InputAccounting::Camera camera, const sensor_msgs::ImageConstPtr& image);
  void OnCameraInfo(InputAccounting::Camera camera, const sensor_msgs::CameraInfoConstPtr& info);
  /// ExactTime's drop callbacks: a set discarded without all its messages.
  void OnStereoDropped(const sensor_msgs::ImageConstPtr& left,
                       const sensor_msgs::CameraInfoConstPtr& left_info,
                       const sensor_msgs::ImageConstPtr& right,
                       const sensor_msgs::CameraInfoConstPtr& right_info);
  void OnImagesDropped(const sensor_msgs::ImageConstPtr& left,
                       const sensor_msgs::ImageConstPtr& right);
  /// Converts a synchronised pair and posts it to the worker (or refuses it with a warning).
  void Enqueue(const sensor_msgs::Image& left, const sensor_msgs::Image& right,
               const std::shared_ptr<const StereoInfoRectifier>& rectifier);
  /// Warns about bad input, at most once per `kind` every input_warning_period, and counts
  /// the rejection of the pair in progress.
  void RejectInput(const std::string& kind, const std::string& message);
  /// Periodic check: images arriving but no synchronised pair formed (missing camera_info,
  /// unsynchronised stamps, a topic not remapped).
  void CheckInputs(const ros::WallTimerEvent&);
  /// diagnostic_updater tasks (stereo_slam_nodelet_diagnostics.cpp): the input rate against
  /// the expected one with the drop and rejection counts; tracking state, time since the last
  /// good frame, time per frame against the frame period, mapping queue.
  void DiagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void DiagnoseTracking(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// What the diagnostics need from a processed frame (worker thread).
  void NoteForDiagnostics(const StereoFrame& frame, const FrameResult& result);
  void WorkerLoop();
  void ProcessOne(const StereoFrame& frame, const std_msgs::Header& header);
  void Publish(const FrameResult& result, const std_msgs::Header& header);
  /// Markers and the keyframe path from a map snapshot: at most markers_rate, only when the
  /// map (or, for the path, the pose) changed. Worker thread, system_mutex_ held.
  void PublishMap(const std_msgs::Header& header);
  /// The debug image, when subscribed, at most debug_image_rate. Worker thread.
  void PublishDebugImage(const StereoFrame& frame, const FrameResult& result,
                         const std_msgs::Header& header);
  /// Creates the core for `camera` (map_file loaded, localisation-only mode applied). Throws.
  void StartSystemLocked(const StereoCamera& camera);
  /// SlamSystem::Reset, then map_file again when one was given. system_mutex_ held.
  void ResetSystemLocked();
  bool OnSaveMap(pl_slam::SaveMap::Request& req, pl_slam::SaveMap::Response& res);
  bool OnSetLocalizationOnly(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool OnSaveTrajectory(pl_slam::SaveTrajectory::Request& req,
                        pl_slam::SaveTrajectory::Response& res);
  bool OnReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  /// Localisation-only restart: tracking starts again and relocalises in the current map,
  /// which is kept as it is. system_mutex_ held.
  void RestartTrackingLocked();
  /// Sends an empty ~path and a DELETEALL ~markers at once (after a reset). system_mutex_ held.
  void PublishClearedMapLocked();

  using ExactPolicy =
      message_filters::sync_policies::ExactTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                sensor_msgs::Image, sensor_msgs::CameraInfo>;
  using ApproxPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                      sensor_msgs::Image, sensor_msgs::CameraInfo>;
  using ExactImagesPolicy =
      message_filters::sync_policies::ExactTime<sensor_msgs::Image, sensor_msgs::Image>;
  using ApproxImagesPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image>;

  NodeletOptions options_;
  // The subscribers' callbacks run on input_thread_ from input_queue_, never behind a service
  // call or a timer of the nodelet's own queue.
  ros::CallbackQueue input_queue_;
  std::thread input_thread_;
  std::atomic<bool> input_stop_{false};
  std::unique_ptr<InputAccounting> accounting_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter left_sub_, right_sub_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> left_info_sub_, right_info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy>> approx_sync_;
  std::unique_ptr<message_filters::Synchronizer<ExactImagesPolicy>> exact_images_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproxImagesPolicy>> approx_images_sync_;

  ros::Publisher odom_pub_, pose_pub_, path_pub_, status_pub_, markers_pub_;
  ros::Publisher map_cloud_pub_, keyframe_poses_pub_;  // latched, with ~markers
  std::unique_ptr<image_transport::ImageTransport> private_it_;
  image_transport::Publisher debug_pub_;
  ros::ServiceServer save_srv_, reset_srv_, save_map_srv_, localization_srv_;
  ros::WallTimer input_check_timer_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;
  // Diagnostics state, written by the worker and the input callbacks, read by the timer.
  std::mutex diagnostics_mutex_;
  uint32_t diag_pairs_last_ = 0;      // pairs_seen_ at the last input report
  ros::WallTime diag_last_report_;    // when that was
  int64_t diag_last_stamp_ns_ = -1;   // the last processed frame's stamp
  double diag_stamp_period_s_ = 0.0;  // smoothed stamp interval of the input
  double diag_frame_ms_ = 0.0;        // smoothed processing time per frame
  int diag_state_ = -1;               // TrackingState of the last frame, -1 = none yet
  ros::WallTime diag_last_good_;      // wall time of the last frame with a valid pose
  int diag_mapping_queue_ = 0;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_broadcaster_;

  // Input side (subscriber callbacks). The rectifier is rebuilt only when camera_info changes.
  std::mutex input_mutex_;
  std::shared_ptr<const StereoInfoRectifier> rectifier_;
  std::mutex warn_mutex_;  // guards last_warning_ only; never held with another lock
  std::map<std::string, ros::WallTime> last_warning_;  // per kind of bad input
  // Messages seen per input since the last CheckInputs, and pairs synchronised.
  std::atomic<uint32_t> left_seen_{0}, right_seen_{0}, left_info_seen_{0}, right_info_seen_{0};
  std::atomic<uint32_t> pairs_seen_{0};

  // Mailbox between the subscriber callback and the worker: one slot, the newest frame wins.
  // Lock order: mailbox_mutex_ is never held while system_mutex_ is taken or vice versa.
  std::mutex mailbox_mutex_;
  std::condition_variable mailbox_cv_;
  struct Pending {
    StereoFrame frame;  // raw (not yet rectified) mono8 images
    std_msgs::Header header;
    std::shared_ptr<const StereoInfoRectifier> rectifier;
  };
  std::optional<Pending> mailbox_;
  std::atomic<bool> stop_{false};
  std::thread worker_;

  // Owned by the worker thread; services take system_mutex_ to reach it.
  std::mutex system_mutex_;
  std::unique_ptr<SlamSystem> system_;
  StereoCamera camera_;
  std::optional<SE3> T_base_cam_;
  int64_t last_stamp_ns_ = -1;
  uint32_t frames_processed_ = 0;
  nav_msgs::Path path_;  // per-frame path, used while the map has no keyframes (mapping off)
  bool localization_only_ = false;  // wanted mode, applied to every SlamSystem created
  // Map publishing state (worker thread).
  uint64_t published_map_version_ = UINT64_MAX;  // UINT64_MAX = publish at the next chance
  nav_msgs::Path keyframe_path_;                 // from the last snapshot, base poses in map
  bool path_pose_pending_ = false;               // a new pose since the last ~path
  ros::WallTime last_map_publish_, last_debug_image_;
  std::optional<geometry_msgs::PoseStamped> current_pose_;
  ros::Time last_odom_stamp_;  // stamp of the last ~odom: the twist's time step
  // The core's loop count survives SlamSystem::Reset: status reports it minus loops_offset_,
  // taken at the first frame after a reset (no loop can close before that frame).
  int loops_offset_ = 0;
  bool loops_rebase_ = false;
};

}  // namespace ros_layer
}  // namespace pl_slam
