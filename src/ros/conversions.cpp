#include "pl_slam/ros/conversions.h"

#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <sensor_msgs/image_encodings.h>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace ros_layer {

namespace enc = sensor_msgs::image_encodings;

cv::Mat ImageToMono8(const sensor_msgs::Image& msg) {
  // Known encodings only: (OpenCV type, conversion to grey or -1 when none is needed).
  int type = -1, code = -1;
  const std::string& e = msg.encoding;
  if (e == enc::MONO8 || e == enc::TYPE_8UC1)
    type = CV_8UC1;
  else if (e == enc::MONO16 || e == enc::TYPE_16UC1)
    type = CV_16UC1;
  else if (e == enc::RGB8) {
    type = CV_8UC3;
    code = cv::COLOR_RGB2GRAY;
  } else if (e == enc::BGR8) {
    type = CV_8UC3;
    code = cv::COLOR_BGR2GRAY;
  } else if (e == enc::RGBA8) {
    type = CV_8UC4;
    code = cv::COLOR_RGBA2GRAY;
  } else if (e == enc::BGRA8) {
    type = CV_8UC4;
    code = cv::COLOR_BGRA2GRAY;
  } else {
    throw InputError("unsupported image encoding '" + e +
                     "' (expected mono8, mono16, rgb8, bgr8, rgba8 or bgra8)");
  }
  const size_t row_bytes = static_cast<size_t>(msg.width) * CV_ELEM_SIZE(type);
  if (msg.width == 0 || msg.height == 0 || msg.step < row_bytes ||
      msg.data.size() < static_cast<size_t>(msg.step) * msg.height) {
    std::ostringstream os;
    os << "image message " << msg.width << "x" << msg.height << " '" << e
       << "' has inconsistent step " << msg.step << " or data size " << msg.data.size();
    throw InputError(os.str());
  }
  if (msg.is_bigendian && type == CV_16UC1) {
    throw InputError("big-endian mono16 images are not supported");
  }
  const cv::Mat wrapped(static_cast<int>(msg.height), static_cast<int>(msg.width), type,
                        const_cast<uint8_t*>(msg.data.data()), msg.step);
  cv::Mat out;
  if (type == CV_8UC1)
    out = wrapped.clone();
  else if (type == CV_16UC1)
    wrapped.convertTo(out, CV_8UC1, 1.0 / 256.0);
  else
    cv::cvtColor(wrapped, out, code);
  return out;
}

StereoCamera StereoCameraFromInfo(const sensor_msgs::CameraInfo& left,
                                  const sensor_msgs::CameraInfo& right) {
  auto fail = [](const std::string& what) { throw InputError("camera_info: " + what); };
  if (left.P[0] <= 0.0 || left.P[5] <= 0.0)
    fail("left P has no focal length (camera not calibrated?)");
  if (right.P[0] <= 0.0) fail("right P has no focal length (camera not calibrated?)");
  if (left.width != right.width || left.height != right.height) {
    std::ostringstream os;
    os << "left " << left.width << "x" << left.height << " and right " << right.width << "x"
       << right.height << " sizes differ";
    fail(os.str());
  }
  // A rectified pair shares fx, fy and cy; the principal points' x may differ (stereoRectify
  // without CALIB_ZERO_DISPARITY): that difference is the camera's doffs.
  if (std::abs(left.P[0] - right.P[0]) > 1e-3 * left.P[0] ||
      std::abs(left.P[5] - right.P[5]) > 1e-3 * left.P[5] ||
      std::abs(left.P[6] - right.P[6]) > 0.5) {
    fail(
        "left and right projection matrices differ in focal length or cy: the pair is not "
        "rectified");
  }
  StereoCamera cam;
  cam.fx = left.P[0];
  cam.cx = left.P[2];
  cam.fy = left.P[5];
  cam.cy = left.P[6];
  cam.baseline = -right.P[3] / right.P[0];
  cam.doffs = right.P[2] - left.P[2];
  cam.width = static_cast<int>(left.width);
  cam.height = static_cast<int>(left.height);
  const std::string err = cam.Validate();
  if (!err.empty()) fail(err);
  return cam;
}

void StereoCameraToInfo(const StereoCamera& camera, const std::string& left_frame,
                        const std::string& right_frame, sensor_msgs::CameraInfo* left,
                        sensor_msgs::CameraInfo* right) {
  for (int side = 0; side < 2; ++side) {
    sensor_msgs::CameraInfo& info = side == 0 ? *left : *right;
    info.header.frame_id = side == 0 ? left_frame : right_frame;
    info.width = static_cast<uint32_t>(camera.width);
    info.height = static_cast<uint32_t>(camera.height);
    info.distortion_model = "plumb_bob";
    info.D.assign(5, 0.0);
    info.K = {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
    info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    const double tx = side == 0 ? 0.0 : -camera.fx * camera.baseline;
    const double cx = side == 0 ? camera.cx : camera.cx + camera.doffs;
    info.P = {camera.fx, 0.0, cx, tx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  }
}

ros::Time FromNanoseconds(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(std::max<int64_t>(ns, 0)));
  return t;
}

geometry_msgs::Pose ToPoseMsg(const SE3& T) {
  geometry_msgs::Pose p;
  p.position.x = T.translation().x();
  p.position.y = T.translation().y();
  p.position.z = T.translation().z();
  p.orientation.w = T.so3().w();
  p.orientation.x = T.so3().x();
  p.orientation.y = T.so3().y();
  p.orientation.z = T.so3().z();
  return p;
}

SE3 FromPoseMsg(const geometry_msgs::Pose& p) {
  Eigen::Quaterniond q(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z);
  if (!(q.norm() > 1e-9)) q = Eigen::Quaterniond::Identity();
  return SE3(q, Eigen::Vector3d(p.position.x, p.position.y, p.position.z));
}

}  // namespace ros_layer
}  // namespace pl_slam
