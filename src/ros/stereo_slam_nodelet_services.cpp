// StereoSlamNodelet, services: save_trajectory, save_map, set_localization_only, reset.
#include <string>
#include <vector>

#include "pl_slam/io/trajectory.h"
#include "pl_slam/ros/stamp_policy.h"
#include "pl_slam/ros/stereo_slam_nodelet.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace ros_layer {

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
    // The core's trajectory carries the images' integer stamps (StampedPose::t_ns).
    WriteTrajectory(req.path, traj, format);
    res.success = true;
    res.poses = static_cast<uint32_t>(traj.size());
    res.message = "wrote " + std::to_string(traj.size()) + " poses to " + req.path +
                  " (frames processed " + std::to_string(processed) + ", dropped " +
                  std::to_string(accounting_ ? accounting_->counts().dropped : 0) + ")";
    NODELET_INFO("pl_slam: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    NODELET_WARN("pl_slam: save_trajectory failed: %s", e.what());
  }
  return true;
}

bool StereoSlamNodelet::OnSaveMap(pl_slam::SaveMap::Request& req, pl_slam::SaveMap::Response& res) {
  try {
    if (req.path.empty()) throw InputError("path is empty");
    if (!options_.system.mapping.enabled)
      throw InputError("mapping.enabled=false: there is no map to save");
    std::lock_guard<std::mutex> lock(system_mutex_);
    if (!system_) throw InputError("no map yet: no frame has been processed");
    system_->Flush();  // the keyframes still queued for local mapping belong in the file
    system_->SaveMap(req.path);
    const MapCounts counts = system_->map().counts();
    res.success = true;
    res.message = "wrote the map (" + std::to_string(counts.keyframes) + " keyframes, " +
                  std::to_string(counts.points) + " points, " + std::to_string(counts.lines) +
                  " lines) to " + req.path;
    NODELET_INFO("pl_slam: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    NODELET_WARN("pl_slam: save_map failed: %s", e.what());
  }
  return true;
}

bool StereoSlamNodelet::OnSetLocalizationOnly(std_srvs::SetBool::Request& req,
                                              std_srvs::SetBool::Response& res) {
  if (!options_.system.mapping.enabled) {
    res.success = false;
    res.message = "mapping.enabled=false: there is no map to localise in";
    NODELET_WARN("pl_slam: set_localization_only refused: %s", res.message.c_str());
    return true;
  }
  std::lock_guard<std::mutex> lock(system_mutex_);
  localization_only_ = req.data;
  if (system_) system_->SetLocalizationOnly(req.data);
  res.success = true;
  res.message = req.data ? "localisation only: tracking in the map, no new keyframes"
                         : "mapping: new keyframes are added to the map";
  NODELET_INFO("pl_slam: %s", res.message.c_str());
  return true;
}

bool StereoSlamNodelet::OnReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(system_mutex_);
  ResetSystemLocked();  // counters restart; an empty ~path and a DELETEALL ~markers go out now
  last_stamp_ns_ = -1;
  res.success = true;
  res.message = options_.map_file.empty()
                    ? "map, trajectory and counters cleared"
                    : "trajectory and counters cleared, map reloaded from " + options_.map_file;
  NODELET_INFO("pl_slam: reset");
  return true;
}

}  // namespace ros_layer
}  // namespace pl_slam
