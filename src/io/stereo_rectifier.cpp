#include "pl_slam/io/stereo_rectifier.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

bool SameValue(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); }

cv::Mat ToCv(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  }
  return out;
}

}  // namespace

StereoRectifier::StereoRectifier(const RawCameraCalibration& left,
                                 const RawCameraCalibration& right) {
  const std::string pair = left.source + " + " + right.source;
  for (const RawCameraCalibration* c : {&left, &right}) {
    const std::string err = c->Validate();
    if (!err.empty()) throw InputError(c->source + ": " + err);
  }
  if (left.width != right.width || left.height != right.height) {
    std::ostringstream os;
    os << right.source << ": resolution " << right.width << "x" << right.height
       << " differs from the left camera's " << left.width << "x" << left.height << " ("
       << left.source << ")";
    throw InputError(os.str());
  }
  raw_width_ = left.width;
  raw_height_ = left.height;
  T_c1_c0_ = right.T_b_s.inverse() * left.T_b_s;
  const Eigen::Vector3d t = T_c1_c0_.translation();

  // Already rectified: skip OpenCV, whose stereoRectify re-chooses the focal length and
  // principal point even for a perfect pair, and keep the raw numbers exactly.
  identity_ = !left.HasDistortion() && !right.HasDistortion() && SameValue(left.fu, right.fu) &&
              SameValue(left.fv, right.fv) && SameValue(left.cu, right.cu) &&
              SameValue(left.cv, right.cv) && T_c1_c0_.RotationAngle() < 1e-9 && t.x() < 0.0 &&
              std::abs(t.y()) <= 1e-9 * std::abs(t.x()) &&
              std::abs(t.z()) <= 1e-9 * std::abs(t.x());

  camera_.width = left.width;
  camera_.height = left.height;
  if (identity_) {
    camera_.fx = left.fu;
    camera_.fy = left.fv;
    camera_.cx = left.cu;
    camera_.cy = left.cv;
    camera_.baseline = -t.x();
    T_c0_crect_ = SE3();
    R1_ = cv::Mat::eye(3, 3, CV_64F);
    R2_ = cv::Mat::eye(3, 3, CV_64F);
    P1_ = cv::Mat::zeros(3, 4, CV_64F);
    cv::Mat(cv::Mat(left.K())).copyTo(P1_(cv::Rect(0, 0, 3, 3)));
    P2_ = P1_.clone();
    P2_.at<double>(0, 3) = -camera_.fx * camera_.baseline;
  } else {
    const cv::Mat K1(left.K()), K2(right.K());
    const cv::Mat D1 = cv::Mat(left.distortion, true);
    const cv::Mat D2 = cv::Mat(right.distortion, true);
    const cv::Mat R = ToCv(T_c1_c0_.rotation());
    const cv::Mat T = (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
    const cv::Size size(left.width, left.height);
    cv::Mat Q;
    cv::stereoRectify(K1, D1, K2, D2, size, R, T, R1_, R2_, P1_, P2_, Q, cv::CALIB_ZERO_DISPARITY,
                      0.0, size);
    if (std::abs(P2_.at<double>(1, 3)) > std::abs(P2_.at<double>(0, 3))) {
      throw InputError(pair +
                       ": the cameras are stacked vertically; only horizontal stereo is "
                       "supported");
    }
    camera_.fx = P1_.at<double>(0, 0);
    camera_.fy = P1_.at<double>(1, 1);
    camera_.cx = P1_.at<double>(0, 2);
    camera_.cy = P1_.at<double>(1, 2);
    camera_.baseline = -P2_.at<double>(0, 3) / P2_.at<double>(0, 0);
    Eigen::Matrix3d R1;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R1(r, c) = R1_.at<double>(r, c);
    }
    // p_rect = R1 * p_raw, so the rectified camera's orientation in the raw frame is R1^T.
    T_c0_crect_ = SE3(Eigen::Matrix3d(R1.transpose()), Eigen::Vector3d::Zero());
    cv::initUndistortRectifyMap(K1, D1, R1_, P1_, size, CV_16SC2, left_map1_, left_map2_);
    cv::initUndistortRectifyMap(K2, D2, R2_, P2_, size, CV_16SC2, right_map1_, right_map2_);
  }
  if (!(camera_.baseline > 0.0)) {
    std::ostringstream os;
    os << pair << ": the right camera is not on the left camera's +x side (baseline "
       << camera_.baseline << " m); are cam0 and cam1 swapped?";
    throw InputError(os.str());
  }
  const std::string err = camera_.Validate();
  if (!err.empty()) throw InputError(pair + ": rectified camera unusable: " + err);
}

void StereoRectifier::RectifyLeft(const cv::Mat& raw, cv::Mat* out) const {
  Apply(raw, left_map1_, left_map2_, out);
}

void StereoRectifier::RectifyRight(const cv::Mat& raw, cv::Mat* out) const {
  Apply(raw, right_map1_, right_map2_, out);
}

void StereoRectifier::Apply(const cv::Mat& raw, const cv::Mat& map1, const cv::Mat& map2,
                            cv::Mat* out) const {
  if (raw.cols != raw_width_ || raw.rows != raw_height_ || raw.type() != CV_8UC1) {
    std::ostringstream os;
    os << "StereoRectifier: image is " << raw.cols << "x" << raw.rows << " type " << raw.type()
       << ", expected " << raw_width_ << "x" << raw_height_ << " CV_8UC1";
    throw InputError(os.str());
  }
  if (identity_) {
    *out = raw;
    return;
  }
  // Always into a fresh buffer: *out may share pixels with images a consumer still holds
  // (frames are immutable once handed out), and cv::remap cannot work in place.
  cv::Mat rectified;
  cv::remap(raw, rectified, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  *out = rectified;
}

}  // namespace pl_slam
