// The SlamSystem facade over the pipeline modules. Tracking is the point + line stereo
// tracker; mapping and loop closure plug in behind the same interface.
#include "pl_slam/system/slam_system.h"

#include <chrono>
#include <mutex>

#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {

const char* TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized:
      return "NOT_INITIALIZED";
    case TrackingState::kTracking:
      return "TRACKING";
    case TrackingState::kLost:
      return "LOST";
  }
  return "UNKNOWN";
}

std::string SystemOptions::Validate() const {
  const std::string err = tracker.Validate();
  return err.empty() ? err : "tracker." + err;
}

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

struct SlamSystem::Impl {
  StereoCamera camera;
  SystemOptions options;
  std::unique_ptr<StereoTracker> tracker;
  TrackingState state = TrackingState::kNotInitialized;
  SE3 T_w_c;
  mutable std::mutex trajectory_mutex;  // guards trajectory only (read from other threads)
  Trajectory trajectory;
};

SlamSystem::SlamSystem(const StereoCamera& camera, const SystemOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const std::string cam_error = camera.Validate();
  if (!cam_error.empty()) throw ConfigError("camera: " + cam_error);
  const std::string opt_error = options.Validate();
  if (!opt_error.empty()) throw ConfigError(opt_error);
  impl_->camera = camera;
  impl_->options = options;
  impl_->tracker = std::make_unique<StereoTracker>(camera, options.tracker);
}

SlamSystem::~SlamSystem() = default;

const StereoCamera& SlamSystem::camera() const { return impl_->camera; }

void SlamSystem::Reset() {
  impl_->tracker->Reset();
  impl_->state = TrackingState::kNotInitialized;
  impl_->T_w_c = SE3();
  std::lock_guard<std::mutex> lock(impl_->trajectory_mutex);
  impl_->trajectory.clear();
}

Trajectory SlamSystem::trajectory() const {
  std::lock_guard<std::mutex> lock(impl_->trajectory_mutex);
  return impl_->trajectory;
}

FrameResult SlamSystem::Process(const StereoFrame& frame) {
  Impl& s = *impl_;
  const auto t_start = Clock::now();
  FrameResult result;
  result.T_w_c = s.T_w_c;

  const cv::Size expected(s.camera.width, s.camera.height);
  std::string bad;
  if (frame.left.empty() || frame.right.empty())
    bad = "empty image";
  else if (frame.left.type() != CV_8UC1 || frame.right.type() != CV_8UC1)
    bad = "images must be 8-bit single channel";
  else if (frame.left.size() != frame.right.size())
    bad = "left and right image sizes differ";
  else if (frame.left.size() != expected)
    bad = "image size differs from the calibration";
  if (!bad.empty()) {
    PL_LOG_WARN("frame " << frame.index << ": " << bad << "; frame skipped, tracking lost");
    if (s.state != TrackingState::kNotInitialized) s.state = TrackingState::kLost;
    result.state = s.state;
    result.warning = bad;
    result.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
    return result;
  }

  const TrackerResult r = s.tracker->Track(frame);
  const TrackingState previous = s.state;
  s.state = static_cast<TrackingState>(r.state);
  if (!r.warning.empty() &&
      (r.state == TrackerState::kLost && previous == TrackingState::kTracking)) {
    PL_LOG_WARN("frame " << frame.index << ": tracking lost (" << r.warning
                         << "); restarting from the last pose");
  } else if (!r.warning.empty() && r.state != TrackerState::kTracking) {
    PL_LOG_DEBUG("frame " << frame.index << ": " << r.warning);
  } else if (r.state == TrackerState::kTracking && previous == TrackingState::kLost) {
    PL_LOG_INFO("frame " << frame.index << ": tracking recovered");
  }
  s.T_w_c = r.T_w_c;
  result.state = s.state;
  result.T_w_c = r.T_w_c;
  result.pose_valid = r.pose_valid;
  result.covariance = r.covariance_prev_cur;
  result.is_keyframe = r.is_keyframe;
  result.points_detected = r.points_detected;
  result.lines_detected = r.lines_detected;
  result.point_inliers = r.point_inliers;
  result.line_inliers = r.line_inliers;
  result.warning = r.warning;
  result.stage_ms = r.stage_ms;
  if (r.pose_valid) {
    std::lock_guard<std::mutex> lock(s.trajectory_mutex);
    StampedPose sp;
    sp.t = frame.stamp_s();
    sp.T_w_c = r.T_w_c;
    s.trajectory.push_back(sp);
  }
  result.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
  return result;
}

}  // namespace pl_slam
