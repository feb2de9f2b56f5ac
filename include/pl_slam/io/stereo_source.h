// Sources of rectified stereo frames: dataset folders (EuRoC ASL, KITTI odometry), rosbags
// (in the ROS layer) and the synthetic generator all implement this interface.
#pragma once

#include <memory>
#include <string>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/io/stereo_frame.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {

/// A finite, forward-only sequence of rectified stereo frames with its calibration and,
/// when the dataset has one, the ground-truth trajectory of the left camera.
class StereoSource {
 public:
  virtual ~StereoSource() = default;

  /// Rectified calibration shared by every frame.
  virtual const StereoCamera& camera() const = 0;
  /// Number of frames in the sequence.
  virtual std::size_t size() const = 0;
  /// Reads the next frame into *frame; false at the end. Throws InputError on an unreadable
  /// image (naming the file).
  virtual bool Next(StereoFrame* frame) = 0;
  /// Ground-truth poses of the left (rectified) camera in a world frame; empty when none.
  virtual const Trajectory& ground_truth() const = 0;
  /// Short description (kind and path) for logs.
  virtual std::string Describe() const = 0;
};

/// Opens a dataset folder, detecting its layout: an EuRoC ASL folder (contains mav0/ or
/// cam0/ + cam1/) or a KITTI odometry sequence (calib.txt + image_0/ + image_1/). Throws
/// InputError naming the path and what is missing. Bags are opened by the ROS layer.
std::unique_ptr<StereoSource> OpenDatasetFolder(const std::string& path);

}  // namespace pl_slam
