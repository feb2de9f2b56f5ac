#include "pl_slam/ros/map_visualization.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

#include "pl_slam/ros/conversions.h"

namespace pl_slam {
namespace ros_layer {

namespace {

geometry_msgs::Point ToPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point m;
  m.x = p.x();
  m.y = p.y();
  m.z = p.z();
  return m;
}

std_msgs::ColorRGBA Rgba(float r, float g, float b, float a = 1.0f) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

visualization_msgs::Marker MakeMarker(const std::string& frame, const ros::Time& stamp,
                                      const char* ns, int32_t type, double width,
                                      const std_msgs::ColorRGBA& color) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = 0;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.scale.y = width;
  m.color = color;
  return m;
}

/// The marker itself, or a DELETE of its namespace/id when it has no points.
visualization_msgs::Marker AddOrDelete(visualization_msgs::Marker m) {
  if (m.points.empty()) {
    m.action = visualization_msgs::Marker::DELETE;
    m.type = visualization_msgs::Marker::POINTS;
  }
  return m;
}

}  // namespace

visualization_msgs::MarkerArray MakeMapMarkers(const MapSnapshot& map, const SE3& T_frame_w,
                                               const std::string& frame, const ros::Time& stamp) {
  using visualization_msgs::Marker;
  visualization_msgs::MarkerArray out;

  Marker points =
      MakeMarker(frame, stamp, kPointsNs, Marker::POINTS, 0.03, Rgba(0.85f, 0.85f, 0.85f));
  points.points.reserve(map.points.size());
  for (const Eigen::Vector3d& p_w : map.points) points.points.push_back(ToPoint(T_frame_w * p_w));
  out.markers.push_back(AddOrDelete(std::move(points)));

  Marker lines =
      MakeMarker(frame, stamp, kLinesNs, Marker::LINE_LIST, 0.015, Rgba(1.0f, 0.45f, 0.0f));
  lines.points.reserve(2 * map.lines.size());
  for (const auto& [P_w, Q_w] : map.lines) {
    lines.points.push_back(ToPoint(T_frame_w * P_w));
    lines.points.push_back(ToPoint(T_frame_w * Q_w));
  }
  out.markers.push_back(AddOrDelete(std::move(lines)));

  // Frustums in the optical frame (z forward, x right, y down): 4:3, 0.15 m deep.
  const double w = 0.1, h = 0.075, d = 0.15;
  const Eigen::Vector3d corners_c[4] = {{-w, -h, d}, {w, -h, d}, {w, h, d}, {-w, h, d}};
  Marker frustums =
      MakeMarker(frame, stamp, kKeyframesNs, Marker::LINE_LIST, 0.008, Rgba(0.2f, 0.5f, 1.0f));
  std::unordered_map<KeyframeId, Eigen::Vector3d> centres;
  for (const auto& kf : map.keyframes) {
    const SE3 T_frame_c = T_frame_w * kf.T_w_c;
    const Eigen::Vector3d o = T_frame_c.translation();
    centres[kf.id] = o;
    Eigen::Vector3d c[4];
    for (int i = 0; i < 4; ++i) c[i] = T_frame_c * corners_c[i];
    for (int i = 0; i < 4; ++i) {
      frustums.points.push_back(ToPoint(o));
      frustums.points.push_back(ToPoint(c[i]));
      frustums.points.push_back(ToPoint(c[i]));
      frustums.points.push_back(ToPoint(c[(i + 1) % 4]));
    }
  }
  out.markers.push_back(AddOrDelete(std::move(frustums)));

  auto edges = [&](const char* ns, double width, const std_msgs::ColorRGBA& color,
                   const std::vector<std::pair<KeyframeId, KeyframeId>>& list) {
    Marker m = MakeMarker(frame, stamp, ns, Marker::LINE_LIST, width, color);
    for (const auto& [a, b] : list) {
      const auto ia = centres.find(a), ib = centres.find(b);
      if (ia == centres.end() || ib == centres.end()) continue;
      m.points.push_back(ToPoint(ia->second));
      m.points.push_back(ToPoint(ib->second));
    }
    return AddOrDelete(std::move(m));
  };
  out.markers.push_back(
      edges(kCovisibilityNs, 0.005, Rgba(0.3f, 0.9f, 0.3f, 0.5f), map.covisibility_edges));
  out.markers.push_back(edges(kLoopEdgesNs, 0.025, Rgba(1.0f, 0.1f, 0.1f), map.loop_edges));
  return out;
}

nav_msgs::Path MakeKeyframePath(const MapSnapshot& map, const SE3& T_frame_w, const SE3& T_base_cam,
                                const std::string& frame) {
  nav_msgs::Path path;
  path.header.frame_id = frame;
  const SE3 T_cam_base = T_base_cam.inverse();
  path.poses.reserve(map.keyframes.size());
  for (const auto& kf : map.keyframes) {
    geometry_msgs::PoseStamped p;
    p.header.frame_id = frame;
    p.header.stamp.fromSec(kf.stamp_s);
    p.pose = ToPoseMsg(T_frame_w * kf.T_w_c * T_cam_base);
    path.poses.push_back(p);
  }
  if (!path.poses.empty()) path.header.stamp = path.poses.back().header.stamp;
  return path;
}

sensor_msgs::PointCloud2 MakeMapCloud(const MapSnapshot& map, const SE3& T_frame_w,
                                      const std::string& frame, const ros::Time& stamp,
                                      double segment_step) {
  struct Sample {
    Eigen::Vector3d p;
    uint8_t source;
  };
  std::vector<Sample> samples;
  samples.reserve(map.points.size() + 4 * map.lines.size());
  for (const Eigen::Vector3d& p_w : map.points) samples.push_back({T_frame_w * p_w, 0});
  if (segment_step > 0.0) {
    for (const auto& [P_w, Q_w] : map.lines) {
      const Eigen::Vector3d P = T_frame_w * P_w, Q = T_frame_w * Q_w;
      const int n = std::max(1, static_cast<int>(std::ceil((Q - P).norm() / segment_step)));
      for (int k = 0; k <= n; ++k)
        samples.push_back({P + (Q - P) * (static_cast<double>(k) / n), 1});
    }
  }
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = frame;
  cloud.header.stamp = stamp;
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(samples.size());
  const char* names[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    sensor_msgs::PointField f;
    f.name = names[k];
    f.offset = static_cast<uint32_t>(4 * k);
    f.datatype = sensor_msgs::PointField::FLOAT32;
    f.count = 1;
    cloud.fields.push_back(f);
  }
  sensor_msgs::PointField source;
  source.name = "source";
  source.offset = 12;
  source.datatype = sensor_msgs::PointField::UINT8;
  source.count = 1;
  cloud.fields.push_back(source);
  cloud.point_step = 16;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_bigendian = false;
  cloud.is_dense = true;
  cloud.data.assign(cloud.row_step, 0);
  for (size_t i = 0; i < samples.size(); ++i) {
    uint8_t* d = cloud.data.data() + i * cloud.point_step;
    const float xyz[3] = {static_cast<float>(samples[i].p.x()),
                          static_cast<float>(samples[i].p.y()),
                          static_cast<float>(samples[i].p.z())};
    std::memcpy(d, xyz, sizeof(xyz));
    d[12] = samples[i].source;
  }
  return cloud;
}

geometry_msgs::PoseArray MakeKeyframePoses(const MapSnapshot& map, const SE3& T_frame_w,
                                           const SE3& T_base_cam, const std::string& frame,
                                           const ros::Time& stamp) {
  geometry_msgs::PoseArray poses;
  poses.header.frame_id = frame;
  poses.header.stamp = stamp;
  const nav_msgs::Path path = MakeKeyframePath(map, T_frame_w, T_base_cam, frame);
  poses.poses.reserve(path.poses.size());
  for (const auto& p : path.poses) poses.poses.push_back(p.pose);
  return poses;
}

cv::Mat DrawDebugImage(const cv::Mat& left, const StereoFeatures& features,
                       const std::string& status) {
  cv::Mat out;
  if (left.channels() == 1)
    cv::cvtColor(left, out, cv::COLOR_GRAY2BGR);
  else
    out = left.clone();
  const cv::Scalar green(0, 220, 0), yellow(0, 230, 255);
  for (const LineFeature& l : features.lines) {
    cv::line(out, cv::Point2d(l.s.x(), l.s.y()), cv::Point2d(l.e.x(), l.e.y()),
             l.has_depth ? green : yellow, 1, cv::LINE_AA);
  }
  for (const PointFeature& p : features.points) {
    cv::circle(out, cv::Point2d(p.uv.x(), p.uv.y()), 3, p.has_depth ? green : yellow, 1,
               cv::LINE_AA);
  }
  if (!status.empty() && out.rows > 24) {
    // A dark band so the text reads on any image.
    cv::Mat band = out(cv::Rect(0, 0, out.cols, 22));
    band *= 0.35;
    const double scale = std::min(0.5, std::max(0.3, out.cols / 1600.0));
    cv::putText(out, status, cv::Point(5, 16), cv::FONT_HERSHEY_SIMPLEX, scale,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  return out;
}

}  // namespace ros_layer
}  // namespace pl_slam
