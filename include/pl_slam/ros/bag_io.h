// Reading stereo sequences from rosbags and writing them (C++ rosbag API, no master needed).
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>

#include "pl_slam/io/stereo_source.h"
#include "pl_slam/ros/camera_info_rectifier.h"

namespace pl_slam {
namespace ros_layer {

/// Topic names of a stereo bag. The defaults are the EuRoC bag layout the generator and the
/// dataset converter write.
struct BagTopics {
  std::string left_image = "/cam0/image_raw";       ///< left sensor_msgs/Image
  std::string right_image = "/cam1/image_raw";      ///< right sensor_msgs/Image
  std::string left_info = "/cam0/camera_info";      ///< left sensor_msgs/CameraInfo
  std::string right_info = "/cam1/camera_info";     ///< right sensor_msgs/CameraInfo
  std::string ground_truth = "/ground_truth/pose";  ///< geometry_msgs/PoseStamped (optional)
};

/// A StereoSource over a bag: left/right images paired by identical header stamps, the
/// rectified calibration from the first camera_info pair (or given), ground truth from the
/// PoseStamped topic when present. Raw images (camera_info with non-zero D, or R not the
/// identity) are rectified from the first camera_info pair as they are read.
class BagStereoSource : public StereoSource {
 public:
  /// Opens the bag. Throws InputError naming the bag and the problem (unreadable, topic
  /// missing, no calibration).
  BagStereoSource(const std::string& path, const BagTopics& topics = BagTopics(),
                  const std::optional<StereoCamera>& calibration = std::nullopt);
  ~BagStereoSource() override;

  const StereoCamera& camera() const override { return camera_; }
  std::size_t size() const override { return size_; }
  bool Next(StereoFrame* frame) override;
  const Trajectory& ground_truth() const override { return ground_truth_; }
  std::string Describe() const override { return "rosbag " + path_; }
  /// Images that found no partner with the same stamp so far.
  int unpaired() const { return unpaired_; }

 private:
  std::string path_;
  BagTopics topics_;
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  StereoCamera camera_;
  std::unique_ptr<StereoInfoRectifier> rectifier_;  // null when the calibration was given
  Trajectory ground_truth_;
  std::size_t size_ = 0;
  int next_index_ = 0;
  int unpaired_ = 0;
  std::map<int64_t, cv::Mat> pending_left_;
  std::map<int64_t, cv::Mat> pending_right_;
};

/// Writes a stereo sequence as a bag in the BagTopics layout: images (mono8), camera_info
/// with identical stamps, and optionally ground truth. The bag appears under its final name
/// only when Close() succeeds (written as <path>.tmp, then renamed).
class StereoBagWriter {
 public:
  /// Throws InputError when the file cannot be created.
  StereoBagWriter(const std::string& path, const StereoCamera& camera,
                  const BagTopics& topics = BagTopics(), const std::string& left_frame = "cam0",
                  const std::string& right_frame = "cam1");
  /// Same, with the camera_info messages given as they are (e.g. a raw camera's K, D, R, P);
  /// their frame_ids name the image frames, their stamps are replaced per frame.
  StereoBagWriter(const std::string& path, const sensor_msgs::CameraInfo& left_info,
                  const sensor_msgs::CameraInfo& right_info, const BagTopics& topics = BagTopics());
  ~StereoBagWriter();

  /// Appends one stereo pair (both images and camera_info stamped with frame.stamp_ns).
  void Write(const StereoFrame& frame);
  /// Appends ground-truth poses (T_w_c of the left camera) on the ground-truth topic.
  void WriteGroundTruth(const Trajectory& T_w_c, const std::string& world_frame = "world");
  /// Finishes the bag and moves it to its final name.
  void Close();

 private:
  void Open();

  std::string path_;
  std::string tmp_path_;
  sensor_msgs::CameraInfo left_info_, right_info_;
  BagTopics topics_;
  rosbag::Bag bag_;
  bool open_ = false;
};

}  // namespace ros_layer
}  // namespace pl_slam
