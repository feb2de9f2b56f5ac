// Rectification from camera_info (K, D, R, P): when it happens, that it puts pixels where
// OpenCV's point model says, and that unusable calibrations are refused with a message.
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "pl_slam/ros/camera_info_rectifier.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace ros_layer {
namespace {

StereoCamera Rectified() { return testing_util::CenteredCamera(300.0, 0.12, 320, 240); }

// A raw pair: distorted plumb_bob cameras, slightly rotated by the rectification, sharing the
// rectified projection of Rectified().
void RawInfos(sensor_msgs::CameraInfo* left, sensor_msgs::CameraInfo* right) {
  StereoCameraToInfo(Rectified(), "l", "r", left, right);
  for (sensor_msgs::CameraInfo* info : {left, right}) {
    info->K = {310.0, 0.0, 162.0, 0.0, 308.0, 118.0, 0.0, 0.0, 1.0};
    info->D = {-0.28, 0.07, 0.0002, 0.00002, 0.0};
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0.01, info == left ? -0.02 : 0.015, 0.005), R);
    for (int i = 0; i < 9; ++i) info->R[i] = R.val[i];
  }
}

TEST(CameraInfoRectifier, RectifiedInfoPassesImagesThroughUnchanged) {
  sensor_msgs::CameraInfo left, right;
  StereoCameraToInfo(Rectified(), "l", "r", &left, &right);
  EXPECT_FALSE(InfoNeedsRectification(left));
  EXPECT_FALSE(InfoNeedsRectification(right));
  const StereoInfoRectifier rect(left, right);
  EXPECT_FALSE(rect.rectifies());
  EXPECT_DOUBLE_EQ(rect.camera().baseline, 0.12);
  const cv::Mat a(240, 320, CV_8UC1, cv::Scalar(7)), b(240, 320, CV_8UC1, cv::Scalar(9));
  cv::Mat out_a, out_b;
  rect.Rectify(a, b, &out_a, &out_b);
  EXPECT_EQ(out_a.data, a.data);  // no copy, no remap
  EXPECT_EQ(out_b.data, b.data);
  // Unset R (all zero) and empty D, as some drivers publish, also mean "rectified".
  left.R.fill(0.0);
  left.D.clear();
  left.distortion_model.clear();
  EXPECT_FALSE(InfoNeedsRectification(left));
}

TEST(CameraInfoRectifier, EachReasonForRectifyingIsDetected) {
  sensor_msgs::CameraInfo left, right;
  StereoCameraToInfo(Rectified(), "l", "r", &left, &right);
  sensor_msgs::CameraInfo d = left, r = left, k = left;
  d.D[0] = -0.1;
  r.R[1] = 0.01;
  k.K[0] = 305.0;
  EXPECT_TRUE(InfoNeedsRectification(d));
  EXPECT_TRUE(InfoNeedsRectification(r));
  EXPECT_TRUE(InfoNeedsRectification(k));
}

TEST(CameraInfoRectifier, RawPixelsLandWhereTheCameraModelPutsThem) {
  sensor_msgs::CameraInfo left, right;
  RawInfos(&left, &right);
  const StereoInfoRectifier rect(left, right);
  ASSERT_TRUE(rect.rectifies());
  EXPECT_NE(rect.Describe().find("plumb_bob"), std::string::npos) << rect.Describe();
  EXPECT_DOUBLE_EQ(rect.camera().fx, 300.0);
  EXPECT_NEAR(rect.camera().baseline, 0.12, 1e-12);

  // A bright blob at a raw pixel must appear where cv::undistortPoints maps that pixel.
  const cv::Matx33d K(left.K.data()), R(left.R.data());
  const cv::Matx34d P(left.P.data());
  for (const cv::Point2d raw_px :
       {cv::Point2d(60, 50), cv::Point2d(250, 190), cv::Point2d(160, 120)}) {
    cv::Mat raw(240, 320, CV_8UC1, cv::Scalar(0));
    cv::circle(raw, cv::Point(cvRound(raw_px.x), cvRound(raw_px.y)), 3, cv::Scalar(255), -1,
               cv::LINE_AA);
    cv::GaussianBlur(raw, raw, cv::Size(0, 0), 1.5);
    cv::Mat out_left, out_right;
    rect.Rectify(raw, raw, &out_left, &out_right);
    ASSERT_EQ(out_left.size(), raw.size());
    cv::Mat blurred;
    cv::GaussianBlur(out_left, blurred, cv::Size(0, 0), 2.0);
    cv::Point found;
    cv::minMaxLoc(blurred, nullptr, nullptr, nullptr, &found);
    std::vector<cv::Point2d> in{cv::Point2d(cvRound(raw_px.x), cvRound(raw_px.y))}, expected;
    cv::undistortPoints(in, expected, K, cv::Mat(left.D), R, P);
    EXPECT_NEAR(found.x, expected[0].x, 1.5) << "raw " << raw_px;
    EXPECT_NEAR(found.y, expected[0].y, 1.5) << "raw " << raw_px;
  }
}

TEST(CameraInfoRectifier, FisheyeAndAlreadyRectifiedOverride) {
  sensor_msgs::CameraInfo left, right;
  RawInfos(&left, &right);
  for (sensor_msgs::CameraInfo* info : {&left, &right}) {
    info->distortion_model = "equidistant";
    info->D = {0.01, -0.005, 0.001, 0.0};
  }
  const StereoInfoRectifier fisheye(left, right);
  EXPECT_TRUE(fisheye.rectifies());
  cv::Mat a(240, 320, CV_8UC1, cv::Scalar(100)), out_a, out_b;
  fisheye.Rectify(a, a, &out_a, &out_b);
  EXPECT_EQ(out_a.size(), a.size());
  // image_rect topics come with the raw camera_info: no second rectification.
  const StereoInfoRectifier as_is(left, right, /*images_rectified=*/true);
  EXPECT_FALSE(as_is.rectifies());
}

TEST(CameraInfoRectifier, ChangedCalibrationIsNoticedAndStampsAreNot) {
  sensor_msgs::CameraInfo left, right;
  RawInfos(&left, &right);
  const StereoInfoRectifier rect(left, right);
  sensor_msgs::CameraInfo l2 = left, r2 = right;
  l2.header.stamp = ros::Time(5.0);
  l2.header.frame_id = "other";
  EXPECT_TRUE(rect.SameCalibration(l2, r2));
  r2.D[0] = -0.3;
  EXPECT_FALSE(rect.SameCalibration(l2, r2));
}

TEST(CameraInfoRectifier, UnusableCalibrationsAreRefusedWithAMessage) {
  sensor_msgs::CameraInfo left, right;
  RawInfos(&left, &right);
  auto message = [](const sensor_msgs::CameraInfo& l, const sensor_msgs::CameraInfo& r) {
    try {
      StereoInfoRectifier rect(l, r);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  sensor_msgs::CameraInfo l = left;
  l.distortion_model = "kannala_brandt_x";
  EXPECT_NE(message(l, right).find("unsupported distortion_model 'kannala_brandt_x'"),
            std::string::npos);
  l = left;
  l.binning_x = 2;
  EXPECT_NE(message(l, right).find("binning"), std::string::npos);
  l = left;
  l.P.fill(0.0);
  EXPECT_NE(message(l, right).find("no focal length"), std::string::npos);
  l = left;
  l.D = {0.1, 0.2, 0.3};
  EXPECT_NE(message(l, right).find("3 coefficients"), std::string::npos);

  const StereoInfoRectifier rect(left, right);
  const cv::Mat small(120, 160, CV_8UC1, cv::Scalar(0)), full(240, 320, CV_8UC1, cv::Scalar(0));
  cv::Mat a, b;
  try {
    rect.Rectify(full, small, &a, &b);
    ADD_FAILURE() << "a right image of the wrong size was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("right image is 160x120"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
