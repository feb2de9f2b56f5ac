#include "pl_slam/ros/map_visualization.h"

#include <cstring>

#include <gtest/gtest.h>

namespace pl_slam {
namespace ros_layer {
namespace {

const visualization_msgs::Marker* Find(const visualization_msgs::MarkerArray& a,
                                       const std::string& ns) {
  for (const auto& m : a.markers)
    if (m.ns == ns) return &m;
  return nullptr;
}

MapSnapshot TwoKeyframeMap() {
  MapSnapshot map;
  MapSnapshot::KeyframePose kf;
  kf.id = 3;
  kf.stamp_s = 10.0;
  map.keyframes.push_back(kf);
  kf.id = 7;
  kf.stamp_s = 11.0;
  kf.T_w_c = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1));  // 1 m forward
  map.keyframes.push_back(kf);
  map.points.emplace_back(0.0, 0.0, 2.0);  // 2 m in front of the first camera
  map.lines.emplace_back(Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(1, 0, 2));
  map.covisibility_edges.emplace_back(3, 7);
  map.loop_edges.emplace_back(3, 99);  // a keyframe not in the snapshot: skipped
  return map;
}

// The camera mount of the launch files: optical frame 1.4 m above a z-up, x-forward base.
SE3 Mount() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // optical z -> base x, optical x -> base -y
  return SE3(Eigen::Quaterniond(R), Eigen::Vector3d(0, 0, 1.4));
}

TEST(MapVisualization, MarkersInTheMapFrameWithTheMount) {
  const MapSnapshot map = TwoKeyframeMap();
  const auto a = MakeMapMarkers(map, Mount(), "map", ros::Time(10.0));
  const auto* points = Find(a, kPointsNs);
  ASSERT_NE(points, nullptr);
  EXPECT_EQ(points->type, visualization_msgs::Marker::POINTS);
  EXPECT_EQ(points->action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(points->header.frame_id, "map");
  ASSERT_EQ(points->points.size(), 1u);
  // 2 m ahead of the camera = 2 m along the base's x, at the camera's height.
  EXPECT_NEAR(points->points[0].x, 2.0, 1e-9);
  EXPECT_NEAR(points->points[0].y, 0.0, 1e-9);
  EXPECT_NEAR(points->points[0].z, 1.4, 1e-9);

  const auto* lines = Find(a, kLinesNs);
  ASSERT_NE(lines, nullptr);
  EXPECT_EQ(lines->type, visualization_msgs::Marker::LINE_LIST);
  ASSERT_EQ(lines->points.size(), 2u);
  EXPECT_NEAR(lines->points[1].y, -1.0, 1e-9);  // optical +x is the base's right (-y)

  const auto* frustums = Find(a, kKeyframesNs);
  ASSERT_NE(frustums, nullptr);
  EXPECT_EQ(frustums->points.size(), 2u * 16u);  // 8 segments per keyframe
  const auto* covis = Find(a, kCovisibilityNs);
  ASSERT_NE(covis, nullptr);
  ASSERT_EQ(covis->points.size(), 2u);
  EXPECT_NEAR(covis->points[1].x, 1.0, 1e-9);  // second keyframe 1 m ahead
  EXPECT_NEAR(covis->points[1].z, 1.4, 1e-9);
  const auto* loops = Find(a, kLoopEdgesNs);
  ASSERT_NE(loops, nullptr);
  EXPECT_EQ(loops->action, visualization_msgs::Marker::DELETE);  // nothing to draw
}

TEST(MapVisualization, EmptyMapDeletesEveryNamespace) {
  const auto a = MakeMapMarkers(MapSnapshot(), SE3(), "map", ros::Time(1.0));
  ASSERT_EQ(a.markers.size(), 5u);
  for (const auto& m : a.markers) EXPECT_EQ(m.action, visualization_msgs::Marker::DELETE) << m.ns;
}

TEST(MapVisualization, KeyframePathIsTheBasePose) {
  const MapSnapshot map = TwoKeyframeMap();
  const SE3 mount = Mount();
  const nav_msgs::Path path = MakeKeyframePath(map, mount, mount, "map");
  ASSERT_EQ(path.poses.size(), 2u);
  EXPECT_EQ(path.header.frame_id, "map");
  // The first keyframe is the SLAM world origin: the base starts at the map origin.
  EXPECT_NEAR(path.poses[0].pose.position.x, 0.0, 1e-9);
  EXPECT_NEAR(path.poses[0].pose.position.z, 0.0, 1e-9);
  EXPECT_NEAR(path.poses[0].pose.orientation.w, 1.0, 1e-9);
  EXPECT_NEAR(path.poses[1].pose.position.x, 1.0, 1e-9);
  EXPECT_NEAR(path.poses[1].pose.position.z, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(path.poses[1].header.stamp.toSec(), 11.0);
}

TEST(MapVisualization, CloudHoldsThePointsAndSegmentSamplesInTheMapFrame) {
  const MapSnapshot map = TwoKeyframeMap();
  const SE3 mount = Mount();
  auto read = [](const sensor_msgs::PointCloud2& c, size_t i, float xyz[3]) {
    std::memcpy(xyz, c.data.data() + i * c.point_step, 12);
    return c.data[i * c.point_step + 12];
  };
  const sensor_msgs::PointCloud2 points_only = MakeMapCloud(map, mount, "map", ros::Time(5), 0.0);
  EXPECT_EQ(points_only.header.frame_id, "map");
  ASSERT_EQ(points_only.width, 1u);  // the map point
  EXPECT_EQ(points_only.data.size(), points_only.point_step * points_only.width);
  float xyz[3];
  EXPECT_EQ(read(points_only, 0, xyz), 0);
  // 2 m in front of the camera, which is 1.4 m above the base: x 2, z 1.4 in map.
  EXPECT_NEAR(xyz[0], 2.0, 1e-6);
  EXPECT_NEAR(xyz[1], 0.0, 1e-6);
  EXPECT_NEAR(xyz[2], 1.4, 1e-6);
  // The 1 m segment (optical x, so map -y) sampled every 0.25 m: 5 samples.
  const sensor_msgs::PointCloud2 with_lines = MakeMapCloud(map, mount, "map", ros::Time(5), 0.25);
  ASSERT_EQ(with_lines.width, 6u);
  EXPECT_EQ(read(with_lines, 5, xyz), 1);
  EXPECT_NEAR(xyz[1], -1.0, 1e-6);
  EXPECT_EQ(read(with_lines, 1, xyz), 1);
  EXPECT_NEAR(xyz[1], 0.0, 1e-6);
  const geometry_msgs::PoseArray poses = MakeKeyframePoses(map, mount, mount, "map", ros::Time(5));
  ASSERT_EQ(poses.poses.size(), 2u);
  EXPECT_NEAR(poses.poses[1].position.x, 1.0, 1e-9);
}

TEST(MapVisualization, DebugImageColoursByDepth) {
  cv::Mat left(120, 160, CV_8UC1, cv::Scalar(100));
  StereoFeatures f;
  PointFeature p;
  p.uv = Eigen::Vector2d(40, 60);
  p.has_depth = true;
  f.points.push_back(p);
  p.uv = Eigen::Vector2d(120, 60);
  p.has_depth = false;
  f.points.push_back(p);
  LineFeature l;
  l.s = Eigen::Vector2d(20, 100);
  l.e = Eigen::Vector2d(140, 100);
  l.has_depth = true;
  f.lines.push_back(l);
  const cv::Mat out = DrawDebugImage(left, f, "TRACKING");
  ASSERT_EQ(out.type(), CV_8UC3);
  ASSERT_EQ(out.size(), left.size());
  const auto is_green = [](const cv::Vec3b& c) { return c[1] > 150 && c[2] < 80; };
  const auto is_yellow = [](const cv::Vec3b& c) { return c[1] > 150 && c[2] > 150 && c[0] < 80; };
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(60, 43)));    // circle of radius 3 around (40, 60)
  EXPECT_TRUE(is_yellow(out.at<cv::Vec3b>(60, 123)));  // no depth
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(100, 80)));   // segment with depth
  EXPECT_EQ(out.at<cv::Vec3b>(80, 80), cv::Vec3b(100, 100, 100));  // untouched
  EXPECT_LT(out.at<cv::Vec3b>(2, 150)[0], 100);                    // the status band
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
