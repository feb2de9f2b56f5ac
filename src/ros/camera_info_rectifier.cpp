#include "pl_slam/ros/camera_info_rectifier.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace ros_layer {

namespace {

bool AllZero(const std::vector<double>& d) {
  return std::all_of(d.begin(), d.end(), [](double v) { return v == 0.0; });
}

bool IsIdentity(const boost::array<double, 9>& R) {
  // An all-zero R means "not set" in many drivers; treat it as the identity.
  if (std::all_of(R.begin(), R.end(), [](double v) { return v == 0.0; })) return true;
  for (int i = 0; i < 9; ++i) {
    if (std::abs(R[i] - (i % 4 == 0 ? 1.0 : 0.0)) > 1e-9) return false;
  }
  return true;
}

bool KMatchesP(const sensor_msgs::CameraInfo& info) {
  // An all-zero K means "not set": nothing to compare with.
  if (std::all_of(info.K.begin(), info.K.end(), [](double v) { return v == 0.0; })) return true;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const double k = info.K[r * 3 + c], p = info.P[r * 4 + c];
      if (std::abs(k - p) > 1e-6 * std::max(1.0, std::abs(p))) return false;
    }
  }
  return true;
}

// The fields that define the calibration (not the header).
bool SameFields(const sensor_msgs::CameraInfo& a, const sensor_msgs::CameraInfo& b) {
  return a.width == b.width && a.height == b.height && a.distortion_model == b.distortion_model &&
         a.D == b.D && a.K == b.K && a.R == b.R && a.P == b.P && a.binning_x == b.binning_x &&
         a.binning_y == b.binning_y && a.roi.x_offset == b.roi.x_offset &&
         a.roi.y_offset == b.roi.y_offset && a.roi.width == b.roi.width &&
         a.roi.height == b.roi.height;
}

void CheckSupported(const sensor_msgs::CameraInfo& info, const char* side) {
  const std::string prefix = std::string("camera_info: ") + side + " ";
  if (info.binning_x > 1 || info.binning_y > 1) {
    throw InputError(prefix + "binning " + std::to_string(info.binning_x) + "x" +
                     std::to_string(info.binning_y) + " is not supported (expected 0 or 1)");
  }
  const bool full_roi = (info.roi.width == 0 && info.roi.height == 0) ||
                        (info.roi.x_offset == 0 && info.roi.y_offset == 0 &&
                         info.roi.width == info.width && info.roi.height == info.height);
  if (!full_roi) throw InputError(prefix + "region of interest is not supported (use full images)");
  const std::string& m = info.distortion_model;
  if (AllZero(info.D)) return;
  if (m == "plumb_bob" || m == "rational_polynomial") {
    if (info.D.size() != 4 && info.D.size() != 5 && info.D.size() != 8 && info.D.size() != 12 &&
        info.D.size() != 14) {
      throw InputError(prefix + "distortion_model " + m + " with " + std::to_string(info.D.size()) +
                       " coefficients (expected 4, 5, 8, 12 or 14)");
    }
  } else if (m == "equidistant") {
    if (info.D.size() != 4)
      throw InputError(prefix + "distortion_model equidistant needs 4 coefficients, got " +
                       std::to_string(info.D.size()));
  } else {
    throw InputError(prefix + "unsupported distortion_model '" + m +
                     "' (expected plumb_bob, rational_polynomial or equidistant)");
  }
}

void BuildMaps(const sensor_msgs::CameraInfo& info, cv::Mat* map1, cv::Mat* map2) {
  const cv::Matx33d K(info.K.data());
  const cv::Matx33d R = IsIdentity(info.R) ? cv::Matx33d::eye() : cv::Matx33d(info.R.data());
  const cv::Matx33d P(info.P[0], info.P[1], info.P[2], info.P[4], info.P[5], info.P[6], info.P[8],
                      info.P[9], info.P[10]);
  const cv::Size size(static_cast<int>(info.width), static_cast<int>(info.height));
  const bool no_k = std::all_of(info.K.begin(), info.K.end(), [](double v) { return v == 0.0; });
  if (no_k) throw InputError("camera_info: K is not set but the image needs rectification");
  if (info.distortion_model == "equidistant" && !AllZero(info.D)) {
    cv::fisheye::initUndistortRectifyMap(K, info.D, R, P, size, CV_16SC2, *map1, *map2);
  } else {
    const cv::Mat D = AllZero(info.D) ? cv::Mat() : cv::Mat(info.D, true);
    cv::initUndistortRectifyMap(K, D, R, P, size, CV_16SC2, *map1, *map2);
  }
}

}  // namespace

bool InfoNeedsRectification(const sensor_msgs::CameraInfo& info) {
  return !AllZero(info.D) || !IsIdentity(info.R) || !KMatchesP(info);
}

StereoInfoRectifier::StereoInfoRectifier(const sensor_msgs::CameraInfo& left,
                                         const sensor_msgs::CameraInfo& right,
                                         bool images_rectified)
    : left_info_(left), right_info_(right) {
  left_info_.header = right_info_.header = std_msgs::Header();
  camera_ = StereoCameraFromInfo(left, right);
  if (images_rectified) return;
  rectifies_ = InfoNeedsRectification(left) || InfoNeedsRectification(right);
  if (!rectifies_) return;
  CheckSupported(left, "left");
  CheckSupported(right, "right");
  BuildMaps(left, &left_map1_, &left_map2_);
  BuildMaps(right, &right_map1_, &right_map2_);
}

bool StereoInfoRectifier::SameCalibration(const sensor_msgs::CameraInfo& left,
                                          const sensor_msgs::CameraInfo& right) const {
  return SameFields(left, left_info_) && SameFields(right, right_info_);
}

void StereoInfoRectifier::Rectify(const cv::Mat& raw_left, const cv::Mat& raw_right, cv::Mat* left,
                                  cv::Mat* right) const {
  for (int side = 0; side < 2; ++side) {
    const cv::Mat& raw = side == 0 ? raw_left : raw_right;
    if (raw.cols != camera_.width || raw.rows != camera_.height) {
      std::ostringstream os;
      os << (side == 0 ? "left" : "right") << " image is " << raw.cols << "x" << raw.rows
         << " but its camera_info says " << camera_.width << "x" << camera_.height;
      throw InputError(os.str());
    }
  }
  if (!rectifies_) {
    *left = raw_left;
    *right = raw_right;
    return;
  }
  cv::remap(raw_left, *left, left_map1_, left_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(raw_right, *right, right_map1_, right_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
}

std::string StereoInfoRectifier::Describe() const {
  std::ostringstream os;
  os << camera_.width << "x" << camera_.height << ", fx " << std::fixed << std::setprecision(1)
     << camera_.fx << ", baseline " << std::setprecision(4) << camera_.baseline << " m, ";
  if (rectifies_) {
    os << "rectifying raw images ("
       << (left_info_.distortion_model.empty() ? "no distortion" : left_info_.distortion_model)
       << ")";
  } else {
    os << "images already rectified";
  }
  return os.str();
}

}  // namespace ros_layer
}  // namespace pl_slam
