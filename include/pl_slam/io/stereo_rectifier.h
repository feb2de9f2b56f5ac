// Rectification of a raw (distorted, unaligned) stereo pair into the StereoCamera model.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// One raw pinhole camera as a calibration file describes it (EuRoC sensor.yaml schema):
/// intrinsics, radial-tangential distortion, resolution and mounting on the body.
struct RawCameraCalibration {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  std::string source;              ///< file it was read from (named in error messages)
  int width = 0;                   ///< image width in pixels
  int height = 0;                  ///< image height in pixels
  double fu = 0.0;                 ///< focal length x (pixels)
  double fv = 0.0;                 ///< focal length y (pixels)
  double cu = 0.0;                 ///< principal point x (pixels)
  double cv = 0.0;                 ///< principal point y (pixels)
  std::vector<double> distortion;  ///< radial-tangential k1 k2 p1 p2 [k3]; empty = none
  SE3 T_b_s;                       ///< sensor (camera) pose in the body frame ("T_BS")
  double rate_hz = 0.0;            ///< frame rate when the file gives one, else 0

  /// 3x3 camera matrix.
  cv::Matx33d K() const;
  /// True when any distortion coefficient is non-zero.
  bool HasDistortion() const;
  /// Empty string when usable, else a one-line description of the first bad field.
  std::string Validate() const;
};

/// Rectifies raw stereo pairs: cv::stereoRectify (CALIB_ZERO_DISPARITY, alpha 0, so no black
/// borders) and precomputed remap tables. A pair that is already rectified (no distortion,
/// identical intrinsics and resolution, parallel axes, right camera on +x) bypasses OpenCV
/// entirely: images pass through unchanged and the camera keeps the raw intrinsics exactly.
class StereoRectifier {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

  /// An empty rectifier (not usable until assigned).
  StereoRectifier() = default;
  /// Builds the rectification of `left` (cam0) and `right` (cam1). Throws InputError naming the
  /// calibration files when the pair cannot be rectified horizontally (different resolutions,
  /// right camera not on the left camera's +x side, bad intrinsics).
  StereoRectifier(const RawCameraCalibration& left, const RawCameraCalibration& right);

  /// The rectified stereo model (fx, fy, cx, cy from P1; baseline = -P2(0,3) / P2(0,0)).
  const StereoCamera& camera() const { return camera_; }
  /// True when images pass through unchanged (the raw pair was already rectified).
  bool is_identity() const { return identity_; }
  /// Pose of the rectified left camera in the raw left camera frame (rotation R1^T, since the
  /// rectified frame satisfies p_rect = R1 * p_raw).
  const SE3& T_c0_crect() const { return T_c0_crect_; }
  /// Pose of the raw left camera in the raw right camera frame (inv(T_b_s1) * T_b_s0).
  const SE3& T_c1_c0() const { return T_c1_c0_; }
  /// Rectification rotations and projections as cv::stereoRectify returns them (R1, R2 3x3,
  /// P1, P2 3x4, CV_64F); identity / [K | 0], [K | -fx*b] in the bypass case.
  const cv::Mat& R1() const { return R1_; }
  const cv::Mat& R2() const { return R2_; }
  const cv::Mat& P1() const { return P1_; }
  const cv::Mat& P2() const { return P2_; }
  /// Remap tables (CV_16SC2 + CV_16UC1, as cv::initUndistortRectifyMap builds them for
  /// cv::remap); empty in the bypass case.
  const cv::Mat& left_map1() const { return left_map1_; }
  const cv::Mat& left_map2() const { return left_map2_; }
  const cv::Mat& right_map1() const { return right_map1_; }
  const cv::Mat& right_map2() const { return right_map2_; }

  /// Rectifies a raw left image (CV_8UC1 at the raw resolution) into *out. In the bypass case
  /// *out shares the input's pixels. Throws InputError on a size or type mismatch.
  void RectifyLeft(const cv::Mat& raw, cv::Mat* out) const;
  /// Same for a raw right image.
  void RectifyRight(const cv::Mat& raw, cv::Mat* out) const;
  /// Both at once.
  void Rectify(const cv::Mat& raw_left, const cv::Mat& raw_right, cv::Mat* left,
               cv::Mat* right) const {
    RectifyLeft(raw_left, left);
    RectifyRight(raw_right, right);
  }

 private:
  void Apply(const cv::Mat& raw, const cv::Mat& map1, const cv::Mat& map2, cv::Mat* out) const;

  StereoCamera camera_;
  bool identity_ = true;
  SE3 T_c0_crect_;
  SE3 T_c1_c0_;
  cv::Mat R1_, R2_, P1_, P2_;
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
  int raw_width_ = 0;
  int raw_height_ = 0;
};

}  // namespace pl_slam
