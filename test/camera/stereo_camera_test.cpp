#include <gtest/gtest.h>

#include "pl_slam/camera/stereo_camera.h"

namespace pl_slam {
namespace {

StereoCamera Euroc() {
  StereoCamera c;
  c.fx = 435.2;
  c.fy = 435.2;
  c.cx = 367.4;
  c.cy = 252.2;
  c.baseline = 0.11;
  c.width = 752;
  c.height = 480;
  return c;
}

TEST(StereoCamera, ProjectionAndBackProjectionAgree) {
  const StereoCamera c = Euroc();
  const Eigen::Vector3d p(0.4, -0.2, 3.0);
  const Eigen::Vector2d l = c.Project(p), r = c.ProjectRight(p);
  EXPECT_DOUBLE_EQ(l.y(), r.y());  // rectified: same row
  const double d = l.x() - r.x();
  EXPECT_NEAR(d, c.fx * c.baseline / p.z(), 1e-12);
  EXPECT_NEAR(d, c.DisparityFromDepth(3.0), 1e-12);
  EXPECT_LT((c.BackProject(l.x(), l.y(), d) - p).norm(), 1e-12);
  EXPECT_TRUE(c.InImage(l));
  EXPECT_FALSE(c.InImage(Eigen::Vector2d(-1, 10)));
}

TEST(StereoCamera, APrincipalPointOffsetMovesTheRightImageOnly) {
  StereoCamera c = Euroc();
  c.doffs = 1.5;  // the right principal point 1.5 px right of the left one's
  const Eigen::Vector3d p(0.4, -0.2, 3.0);
  const Eigen::Vector2d l = c.Project(p), r = c.ProjectRight(p);
  EXPECT_EQ(l, Euroc().Project(p));
  EXPECT_NEAR(r.x() - Euroc().ProjectRight(p).x(), 1.5, 1e-12);
  const double measured = l.x() - r.x();
  EXPECT_NEAR(measured, c.DisparityFromDepth(3.0), 1e-12);
  EXPECT_NEAR(c.TrueDisparity(measured), c.fx * c.baseline / 3.0, 1e-12);
  EXPECT_NEAR(c.DepthFromDisparity(measured), 3.0, 1e-12);
  EXPECT_LT((c.BackProject(l.x(), l.y(), measured) - p).norm(), 1e-12);
}

TEST(StereoCamera, ValidateNamesTheBadField) {
  EXPECT_EQ(Euroc().Validate(), "");
  StereoCamera c = Euroc();
  c.baseline = 0.0;
  EXPECT_NE(c.Validate().find("baseline"), std::string::npos);
  c = Euroc();
  c.fx = std::nan("");
  EXPECT_NE(c.Validate().find("fx"), std::string::npos);
  c = Euroc();
  c.width = 0;
  EXPECT_NE(c.Validate().find("image size"), std::string::npos);
  c = Euroc();
  c.cy = 900;
  EXPECT_NE(c.Validate().find("cy"), std::string::npos);
  c = Euroc();
  c.doffs = std::nan("");
  EXPECT_NE(c.Validate().find("doffs"), std::string::npos);
  c.doffs = 500;
  EXPECT_NE(c.Validate().find("doffs"), std::string::npos);
}

}  // namespace
}  // namespace pl_slam
