// The one stereo-frame type every input (dataset folders, bags, ROS topics) produces.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace pl_slam {

/// A rectified stereo pair. Images are 8-bit single channel (CV_8UC1) and of equal size;
/// the camera model they obey is the source's StereoCamera.
struct StereoFrame {
  int64_t stamp_ns = 0;  ///< capture time, nanoseconds (dataset clock)
  int index = 0;         ///< position in the sequence, from 0
  cv::Mat left;          ///< rectified left image, CV_8UC1
  cv::Mat right;         ///< rectified right image, CV_8UC1

  /// Time in seconds as a double (for trajectory files).
  double stamp_s() const { return static_cast<double>(stamp_ns) * 1e-9; }
};

}  // namespace pl_slam
