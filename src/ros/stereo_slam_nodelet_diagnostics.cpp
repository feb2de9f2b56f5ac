// StereoSlamNodelet, diagnostics (diagnostic_updater, /diagnostics once a second): is the input
// arriving at the expected rate, and is tracking keeping up and tracking.
#include <algorithm>
#include <cstdio>

#include <diagnostic_msgs/DiagnosticStatus.h>

#include "pl_slam/ros/stereo_slam_nodelet.h"

namespace pl_slam {
namespace ros_layer {

namespace {

using diagnostic_msgs::DiagnosticStatus;

// Smoothing of the per-frame figures: about the last ten frames.
constexpr double kSmoothing = 0.1;
// Lost for longer than this (seconds of wall time since the last good frame) is an error.
constexpr double kLostErrorS = 1.0;

double Smooth(double previous, double value) {
  return previous > 0.0 ? previous + kSmoothing * (value - previous) : value;
}

}  // namespace

void StereoSlamNodelet::NoteForDiagnostics(const StereoFrame& frame, const FrameResult& result) {
  std::lock_guard<std::mutex> lock(diagnostics_mutex_);
  if (diag_last_stamp_ns_ >= 0 && frame.stamp_ns > diag_last_stamp_ns_) {
    const double dt = 1e-9 * static_cast<double>(frame.stamp_ns - diag_last_stamp_ns_);
    // Dropped frames make a gap of several periods: the smallest intervals are the period.
    if (dt < 1.5 * diag_stamp_period_s_ || diag_stamp_period_s_ <= 0.0)
      diag_stamp_period_s_ = Smooth(diag_stamp_period_s_, dt);
  }
  diag_last_stamp_ns_ = frame.stamp_ns;
  diag_frame_ms_ = Smooth(diag_frame_ms_, result.total_ms);
  diag_state_ = static_cast<int>(result.state);
  if (result.pose_valid) diag_last_good_ = ros::WallTime::now();
  diag_mapping_queue_ = system_ ? system_->mapping_stats().queue_length : 0;
}

void StereoSlamNodelet::DiagnoseInput(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const ros::WallTime now = ros::WallTime::now();
  const uint32_t pairs = pairs_seen_.load();
  std::lock_guard<std::mutex> lock(diagnostics_mutex_);
  const double window = diag_last_report_.isZero() ? 0.0 : (now - diag_last_report_).toSec();
  const double rate = window > 0.0 ? (pairs - diag_pairs_last_) / window : 0.0;
  diag_pairs_last_ = pairs;
  diag_last_report_ = now;
  const double expected = options_.expected_rate > 0.0 ? options_.expected_rate
                          : diag_stamp_period_s_ > 0.0 ? 1.0 / diag_stamp_period_s_
                                                       : 0.0;
  char text[160];
  if (pairs == 0) {
    stat.summary(DiagnosticStatus::WARN, "waiting for synchronised stereo pairs");
  } else if (window > 0.0 && rate == 0.0) {
    stat.summary(DiagnosticStatus::ERROR, "no stereo pairs in the last second");
  } else if (expected > 0.0 && rate < 0.75 * expected) {
    std::snprintf(text, sizeof(text), "input at %.1f Hz, expected %.1f Hz", rate, expected);
    stat.summary(DiagnosticStatus::WARN, text);
  } else {
    std::snprintf(text, sizeof(text), "input at %.1f Hz", rate);
    stat.summary(DiagnosticStatus::OK, text);
  }
  stat.add("rate (Hz)", rate);
  stat.add("expected rate (Hz)", expected);
  stat.add("pairs received", pairs);
  const InputCounts c = accounting_->counts();
  stat.add("frames processed", c.processed);
  stat.add("frames dropped (worker behind)", c.dropped);
  stat.add("frames rejected (bad input)", c.rejected);
  stat.add("left images received", c.received[InputAccounting::kLeft]);
  stat.add("right images received", c.received[InputAccounting::kRight]);
  stat.add("left images unpaired", c.unpaired[InputAccounting::kLeft]);
  stat.add("right images unpaired", c.unpaired[InputAccounting::kRight]);
  stat.add("left images waiting", c.waiting[InputAccounting::kLeft]);
  stat.add("right images waiting", c.waiting[InputAccounting::kRight]);
  stat.add("pairs in progress", c.in_progress);
}

void StereoSlamNodelet::DiagnoseTracking(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const ros::WallTime now = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(diagnostics_mutex_);
  const double since_good = diag_last_good_.isZero() ? -1.0 : (now - diag_last_good_).toSec();
  const double period_ms = 1000.0 * diag_stamp_period_s_;
  const auto state = static_cast<TrackingState>(diag_state_);
  char text[160];
  if (diag_state_ < 0) {
    stat.summary(DiagnosticStatus::WARN, "no frame processed yet");
  } else if (state == TrackingState::kNotInitialized) {
    stat.summary(DiagnosticStatus::WARN, "not initialised: too few stereo features");
  } else if (state == TrackingState::kLost) {
    std::snprintf(text, sizeof(text), "tracking lost %.1f s ago", std::max(0.0, since_good));
    stat.summary(since_good < 0.0 || since_good > kLostErrorS ? DiagnosticStatus::ERROR
                                                              : DiagnosticStatus::WARN,
                 text);
  } else if (period_ms > 0.0 && diag_frame_ms_ > period_ms) {
    std::snprintf(text, sizeof(text), "tracking, but %.1f ms per frame for a %.1f ms period",
                  diag_frame_ms_, period_ms);
    stat.summary(DiagnosticStatus::WARN, text);
  } else {
    stat.summary(DiagnosticStatus::OK, "tracking");
  }
  stat.add("state", diag_state_ < 0 ? "NONE" : TrackingStateName(state));
  stat.add("seconds since the last good frame", since_good);
  stat.add("time per frame (ms)", diag_frame_ms_);
  stat.add("frame period (ms)", period_ms);
  stat.add("mapping queue (keyframes)", diag_mapping_queue_);
}

}  // namespace ros_layer
}  // namespace pl_slam
