// Rectification of a stereo pair from its two camera_info messages (K, D, R, P), the way
// image_proc does it, so raw (distorted) camera topics can feed the pipeline directly.
#pragma once

#include <string>

#include <opencv2/core.hpp>
#include <sensor_msgs/CameraInfo.h>

#include "pl_slam/camera/stereo_camera.h"

namespace pl_slam {
namespace ros_layer {

/// True when an image described by `info` must be remapped before it obeys P: a non-zero
/// distortion coefficient, R not the identity, or K different from the left 3x3 block of P.
/// (Rectified camera_info, as StereoCameraToInfo writes it, has D = 0, R = I, K = P3x3.)
bool InfoNeedsRectification(const sensor_msgs::CameraInfo& info);

/// The rectification described by a left/right camera_info pair, computed once (remap tables
/// from cv::initUndistortRectifyMap or cv::fisheye::initUndistortRectifyMap) and applied to
/// every frame. The rectified camera comes from the projection matrices P (see
/// StereoCameraFromInfo). Distortion models: plumb_bob, rational_polynomial, equidistant;
/// an empty model with all-zero D means none.
class StereoInfoRectifier {
 public:
  /// Builds the rectification. With `images_rectified` the images are taken as already
  /// rectified whatever D and R say (e.g. image_rect topics that come with the raw
  /// camera_info): no remap. Throws InputError "camera_info: ..." naming the problem (no P,
  /// unsupported distortion model, binning or ROI, sizes that differ).
  StereoInfoRectifier(const sensor_msgs::CameraInfo& left, const sensor_msgs::CameraInfo& right,
                      bool images_rectified = false);

  /// The rectified stereo model the output images obey.
  const StereoCamera& camera() const { return camera_; }
  /// True when images are remapped; false when they pass through unchanged.
  bool rectifies() const { return rectifies_; }
  /// True when `left` and `right` carry the same calibration (size, distortion model, D, K,
  /// R, P, binning, ROI) as the pair this rectifier was built from; stamps and frames ignored.
  bool SameCalibration(const sensor_msgs::CameraInfo& left,
                       const sensor_msgs::CameraInfo& right) const;
  /// Rectifies a raw pair (CV_8UC1 of the camera_info size). Without rectification the
  /// outputs share the inputs' pixels. Throws InputError naming the side on a size mismatch.
  void Rectify(const cv::Mat& raw_left, const cv::Mat& raw_right, cv::Mat* left,
               cv::Mat* right) const;
  /// One line for logs, e.g. "752x480, fx 435.2, baseline 0.1101 m, rectifying plumb_bob".
  std::string Describe() const;

 private:
  sensor_msgs::CameraInfo left_info_, right_info_;
  StereoCamera camera_;
  bool rectifies_ = false;
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
};

}  // namespace ros_layer
}  // namespace pl_slam
