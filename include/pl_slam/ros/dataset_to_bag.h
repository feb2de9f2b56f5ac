// Dataset folders (EuRoC ASL, KITTI odometry) to rosbags in the package's topic layout: the
// body of the pl_slam_convert tool, a library function so tests can call it.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include "pl_slam/ros/bag_io.h"

namespace pl_slam {
namespace ros_layer {

/// How to convert a dataset folder.
struct ConvertOptions {
  /// EuRoC only: write the distorted images as recorded, with camera_info carrying K, D
  /// (plumb_bob), R and P of the stereo rectification, so a consumer (the nodelet) rectifies.
  /// false: rectified images with rectified camera_info (D = 0, R = I, K = P).
  bool raw = false;
  int max_frames = 0;  ///< convert the first N frames only; 0 = all
  /// Added to every stamp (images, camera_info, ground truth), seconds. NaN = automatic:
  /// 0, or 1000 when the sequence starts before 1 s (ROS time 0 means "unset" and bags cannot
  /// hold it; KITTI times start at 0).
  double time_offset_s = std::numeric_limits<double>::quiet_NaN();
  BagTopics topics;                 ///< topic names (default: the EuRoC bag layout)
  std::string left_frame = "cam0";  ///< frame_id of the left images and camera_info
  std::string right_frame = "cam1";
  std::string world_frame = "world";  ///< frame_id of the ground-truth poses
};

/// What a conversion wrote.
struct ConvertSummary {
  std::string kind;            ///< "EuRoC" or "KITTI"
  std::size_t frames = 0;      ///< stereo pairs written
  std::size_t poses = 0;       ///< ground-truth poses written
  bool raw = false;            ///< distorted images + full calibration written
  double time_offset_s = 0.0;  ///< offset actually added to the stamps
  StereoCamera camera;         ///< rectified calibration
};

/// Converts the dataset folder `input` (layout detected as OpenDatasetFolder does) to the bag
/// `output` (written as <output>.tmp, renamed when complete; the parent folder is created).
/// `progress` is called after every frame with (frames written, total). Throws InputError
/// naming the folder or file and what is wrong (not a dataset folder, unreadable image,
/// --raw on an already rectified dataset), ConfigError for bad options.
ConvertSummary ConvertDatasetToBag(
    const std::string& input, const std::string& output, const ConvertOptions& options,
    const std::function<void(std::size_t, std::size_t)>& progress = nullptr);

}  // namespace ros_layer
}  // namespace pl_slam
