// StereoSlamNodelet, input side: the subscriber callbacks that count every image before the
// synchroniser sees it, stereo pairs from the synchroniser, calibration from camera_info
// (rectification maps), validation of sizes, encodings and stamps, the one-frame mailbox and
// the worker thread that rectifies and feeds the pipeline.
#include <cmath>
#include <iomanip>
#include <sstream>

#include "pl_slam/ros/conversions.h"
#include "pl_slam/ros/stamp_policy.h"
#include "pl_slam/ros/stereo_slam_nodelet.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace ros_layer {

void StereoSlamNodelet::RejectInput(const std::string& kind, const std::string& message) {
  accounting_->Rejected();
  const ros::WallTime now = ros::WallTime::now();
  {
    std::lock_guard<std::mutex> lock(warn_mutex_);
    auto it = last_warning_.find(kind);
    if (it != last_warning_.end() && (now - it->second).toSec() < options_.input_warning_period)
      return;
    last_warning_[kind] = now;
  }
  NODELET_WARN(
      "pl_slam: %s (%u pairs refused so far; repeats of this warning are held back "
      "for %.1f s)",
      message.c_str(), accounting_->counts().rejected, options_.input_warning_period);
}

void StereoSlamNodelet::OnImage(InputAccounting::Camera camera,
                                const sensor_msgs::ImageConstPtr& image) {
  const bool left = camera == InputAccounting::kLeft;
  ++(left ? left_seen_ : right_seen_);
  accounting_->Received(camera, image.get(), ToNanoseconds(image->header.stamp));
  // The synchronisers' slots: (left image, left info, right image, right info) or (left, right).
  if (exact_sync_) {
    left ? exact_sync_->add<0>(image) : exact_sync_->add<2>(image);
  } else if (approx_sync_) {
    left ? approx_sync_->add<0>(image) : approx_sync_->add<2>(image);
  } else if (exact_images_sync_) {
    left ? exact_images_sync_->add<0>(image) : exact_images_sync_->add<1>(image);
  } else if (approx_images_sync_) {
    left ? approx_images_sync_->add<0>(image) : approx_images_sync_->add<1>(image);
  }
  accounting_->AfterSync(camera);
}

void StereoSlamNodelet::OnCameraInfo(InputAccounting::Camera camera,
                                     const sensor_msgs::CameraInfoConstPtr& info) {
  const bool left = camera == InputAccounting::kLeft;
  ++(left ? left_info_seen_ : right_info_seen_);
  if (exact_sync_) {
    left ? exact_sync_->add<1>(info) : exact_sync_->add<3>(info);
  } else if (approx_sync_) {
    left ? approx_sync_->add<1>(info) : approx_sync_->add<3>(info);
  }
}

void StereoSlamNodelet::OnStereoDropped(const sensor_msgs::ImageConstPtr& left,
                                        const sensor_msgs::CameraInfoConstPtr&,
                                        const sensor_msgs::ImageConstPtr& right,
                                        const sensor_msgs::CameraInfoConstPtr&) {
  OnImagesDropped(left, right);
}

void StereoSlamNodelet::OnImagesDropped(const sensor_msgs::ImageConstPtr& left,
                                        const sensor_msgs::ImageConstPtr& right) {
  accounting_->Unpaired(InputAccounting::kLeft, left.get());
  accounting_->Unpaired(InputAccounting::kRight, right.get());
}

void StereoSlamNodelet::CheckInputs(const ros::WallTimerEvent&) {
  const uint32_t left = left_seen_.exchange(0), right = right_seen_.exchange(0);
  const uint32_t left_info = left_info_seen_.exchange(0), right_info = right_info_seen_.exchange(0);
  const uint32_t pairs = pairs_seen_.exchange(0);
  if (left + right == 0 || pairs > 0) return;
  std::ostringstream os;
  os << "no synchronised stereo pair in the last " << options_.input_warning_period
     << " s although images arrive (" << left << " on " << left_sub_.getTopic() << ", " << right
     << " on " << right_sub_.getTopic();
  if (options_.use_camera_info) {
    os << "; camera_info: " << left_info << " on " << left_info_sub_.getTopic() << ", "
       << right_info << " on " << right_info_sub_.getTopic();
  }
  os << "): ";
  if (left == 0 || right == 0) {
    os << "one image topic is silent; check the remapping of left/image and right/image";
  } else if (options_.use_camera_info && (left_info == 0 || right_info == 0)) {
    os << "camera_info is missing; remap left/camera_info and right/camera_info, or set "
          "use_camera_info: false and the camera.* calibration";
  } else if (!options_.approximate_sync) {
    os << "their header stamps differ; exact sync needs identical stamps (set "
          "approximate_sync: true and sync_tolerance)";
  } else {
    os << "their header stamps differ by more than sync_tolerance=" << options_.sync_tolerance
       << " s";
  }
  NODELET_WARN("pl_slam: %s", os.str().c_str());
}

void StereoSlamNodelet::StereoCallback(const sensor_msgs::ImageConstPtr& left,
                                       const sensor_msgs::CameraInfoConstPtr& left_info,
                                       const sensor_msgs::ImageConstPtr& right,
                                       const sensor_msgs::CameraInfoConstPtr& right_info) {
  ++pairs_seen_;
  accounting_->Paired(left.get(), right.get());
  std::shared_ptr<const StereoInfoRectifier> rectifier;
  std::string error;
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    if (!rectifier_ || !rectifier_->SameCalibration(*left_info, *right_info)) {
      // Computed once per calibration (remap tables), again only when camera_info changes.
      try {
        auto fresh = std::make_shared<const StereoInfoRectifier>(*left_info, *right_info,
                                                                 options_.images_rectified);
        if (rectifier_) {
          NODELET_WARN("pl_slam: camera_info changed; rectification recomputed: %s",
                       fresh->Describe().c_str());
        } else {
          NODELET_INFO("pl_slam: calibration from camera_info: %s", fresh->Describe().c_str());
        }
        rectifier_ = fresh;
      } catch (const InputError& e) {
        error = e.what();
      }
    }
    if (error.empty()) rectifier = rectifier_;
  }
  if (!error.empty()) {
    std::ostringstream os;
    os << "stereo pair at " << std::fixed << std::setprecision(3) << left->header.stamp.toSec()
       << " ignored: " << error;
    RejectInput("camera_info", os.str());
    return;
  }
  Enqueue(*left, *right, rectifier);
}

void StereoSlamNodelet::ImagesCallback(const sensor_msgs::ImageConstPtr& left,
                                       const sensor_msgs::ImageConstPtr& right) {
  ++pairs_seen_;
  accounting_->Paired(left.get(), right.get());
  std::shared_ptr<const StereoInfoRectifier> rectifier;
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    rectifier = rectifier_;
  }
  Enqueue(*left, *right, rectifier);
}

void StereoSlamNodelet::Enqueue(const sensor_msgs::Image& left, const sensor_msgs::Image& right,
                                const std::shared_ptr<const StereoInfoRectifier>& rectifier) {
  std::ostringstream where;
  where << "stereo pair at " << std::fixed << std::setprecision(3) << left.header.stamp.toSec()
        << " ignored: ";
  Pending p;
  try {
    p.frame.left = ImageToMono8(left);
    p.frame.right = ImageToMono8(right);
  } catch (const InputError& e) {
    RejectInput("image", where.str() + e.what());
    return;
  }
  const StereoCamera& cam = rectifier->camera();
  if (p.frame.left.size() != p.frame.right.size() || p.frame.left.cols != cam.width ||
      p.frame.left.rows != cam.height) {
    std::ostringstream os;
    os << where.str() << "left " << p.frame.left.cols << "x" << p.frame.left.rows << " and right "
       << p.frame.right.cols << "x" << p.frame.right.rows << " images, calibration " << cam.width
       << "x" << cam.height << " (all three must be equal)";
    RejectInput("size", os.str());
    return;
  }
  p.frame.stamp_ns = ToNanoseconds(left.header.stamp);
  p.header = left.header;
  p.rectifier = rectifier;
  {
    std::lock_guard<std::mutex> lock(mailbox_mutex_);
    if (mailbox_) accounting_->Dropped();  // the worker is behind: the newest pair replaces it
    mailbox_ = std::move(p);
  }
  mailbox_cv_.notify_one();
}

namespace {

bool SameCamera(const StereoCamera& a, const StereoCamera& b) {
  return a.width == b.width && a.height == b.height && std::abs(a.fx - b.fx) <= 1e-6 &&
         std::abs(a.fy - b.fy) <= 1e-6 && std::abs(a.cx - b.cx) <= 1e-6 &&
         std::abs(a.cy - b.cy) <= 1e-6 && std::abs(a.baseline - b.baseline) <= 1e-9 &&
         std::abs(a.doffs - b.doffs) <= 1e-6;
}

}  // namespace

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
    // Rectify here rather than in the callback: frames the worker drops cost no remap.
    StereoFrame frame;
    frame.stamp_ns = p.frame.stamp_ns;
    try {
      p.rectifier->Rectify(p.frame.left, p.frame.right, &frame.left, &frame.right);
    } catch (const InputError& e) {
      RejectInput("size", std::string("stereo pair ignored: ") + e.what());
      continue;
    }
    const StereoCamera& camera = p.rectifier->camera();
    std::lock_guard<std::mutex> lock(system_mutex_);
    if (!system_ || !SameCamera(camera, camera_)) {
      if (system_) NODELET_WARN("pl_slam: the rectified calibration changed; starting a new map");
      try {
        StartSystemLocked(camera);
      } catch (const std::exception& e) {
        NODELET_ERROR_THROTTLE(5.0, "pl_slam: cannot start the pipeline: %s", e.what());
        accounting_->Rejected();
        continue;
      }
    }
    BackwardsStampPolicy policy = BackwardsStampPolicy::kResetAfter;
    ParseBackwardsStampPolicy(options_.backwards_stamp_policy, &policy);  // validated at start
    const auto reset_after_ns =
        static_cast<int64_t>(std::llround(options_.backwards_stamp_reset_after * 1e9));
    const StampAction action =
        ClassifyStamp(last_stamp_ns_, frame.stamp_ns, policy, reset_after_ns);
    if (action == StampAction::kSkipRepeated) {
      RejectInput("stamps", "stereo pair with the same stamp as the previous one skipped");
      continue;
    }
    if (action == StampAction::kSkipBackwards) {
      std::ostringstream os;
      os << "stereo pair stamped " << std::fixed << std::setprecision(3)
         << (last_stamp_ns_ - frame.stamp_ns) * 1e-9
         << " s before the previous one skipped (backwards_stamp_policy="
         << options_.backwards_stamp_policy
         << ", backwards_stamp_reset_after=" << options_.backwards_stamp_reset_after << " s)";
      RejectInput("stamps_backwards", os.str());
      continue;
    }
    if (action == StampAction::kRestart) {
      // A looping bag or a restarted camera clock. While mapping: a new map. In
      // localisation-only mode the map is what the robot localises in: keep it, relocalise.
      if (system_->localization_only()) {
        NODELET_WARN(
            "pl_slam: image stamp went backwards (%.3f after %.3f, bag loop?); localisation "
            "only: keeping the map, restarting tracking to relocalise in it",
            frame.stamp_ns * 1e-9, last_stamp_ns_ * 1e-9);
        RestartTrackingLocked();
      } else {
        NODELET_WARN(
            "pl_slam: image stamp went backwards (%.3f after %.3f, bag loop?); resetting "
            "the map and the trajectory",
            frame.stamp_ns * 1e-9, last_stamp_ns_ * 1e-9);
        ResetSystemLocked();
      }
    }
    last_stamp_ns_ = frame.stamp_ns;
    frame.index = static_cast<int>(frames_processed_);
    ProcessOne(frame, p.header);
  }
}

}  // namespace ros_layer
}  // namespace pl_slam
