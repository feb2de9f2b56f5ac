#include "pl_slam/sim/structural_edges.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pl_slam::sim {
namespace {

// True when the sample at camera-frame point p_c projects inside the image and the rendered
// depth around its pixel agrees with its own depth.
bool SampleVisible(const Eigen::Vector3d& p_c, const StereoCamera& camera, const cv::Mat& depth,
                   const EdgeVisibilityOptions& o, Eigen::Vector2d* uv) {
  if (!(p_c.z() >= o.z_near)) return false;
  *uv = camera.Project(p_c);
  if (!camera.InImage(*uv, o.border_px)) return false;
  const int u = static_cast<int>(std::lround(uv->x()));
  const int v = static_cast<int>(std::lround(uv->y()));
  const double tol = o.depth_abs_m + o.depth_rel * p_c.z();
  for (int dv = -1; dv <= 1; ++dv) {
    const int y = v + dv;
    if (y < 0 || y >= depth.rows) continue;
    const float* row = depth.ptr<float>(y);
    for (int du = -1; du <= 1; ++du) {
      const int x = u + du;
      if (x < 0 || x >= depth.cols) continue;
      if (row[x] > 0.0f && std::abs(row[x] - p_c.z()) <= tol) return true;
    }
  }
  return false;
}

}  // namespace

std::vector<VisibleEdge, Eigen::aligned_allocator<VisibleEdge>> ProjectStructuralEdges(
    const World& world, const StereoCamera& camera, const SE3& T_w_c, const cv::Mat& depth,
    const EdgeVisibilityOptions& options) {
  if (depth.type() != CV_32FC1 || depth.cols != camera.width || depth.rows != camera.height) {
    throw std::invalid_argument(
        "ProjectStructuralEdges: depth must be CV_32FC1 of the camera size");
  }
  const SE3 T_c_w = T_w_c.inverse();
  std::vector<VisibleEdge, Eigen::aligned_allocator<VisibleEdge>> out;
  const auto& edges = world.StructuralEdges();
  for (std::size_t i = 0; i < edges.size(); ++i) {
    Eigen::Vector3d a = T_c_w * edges[i].a;
    Eigen::Vector3d b = T_c_w * edges[i].b;
    // Near-plane clipping in 3D: parameters outside [lo, hi] are behind z_near.
    double lo = 0.0, hi = 1.0;
    const double za = a.z(), zb = b.z();
    if (za < options.z_near && zb < options.z_near) continue;
    if (za < options.z_near) lo = (options.z_near - za) / (zb - za);
    if (zb < options.z_near) hi = (options.z_near - za) / (zb - za);
    const Eigen::Vector3d p0 = a + lo * (b - a), p1 = a + hi * (b - a);
    const double len_px = (camera.Project(p0) - camera.Project(p1)).norm();
    const int n = std::clamp(static_cast<int>(std::ceil(len_px / options.step_px)), 1, 20000);
    int run_start = -1;
    Eigen::Vector2d first_uv, last_uv, uv;
    Eigen::Vector3d first_c, last_c;
    auto close_run = [&]() {
      if (run_start < 0) return;
      run_start = -1;
      if ((last_uv - first_uv).norm() < options.min_length_px) return;
      VisibleEdge e;
      e.edge = static_cast<int>(i);
      e.a = first_uv;
      e.b = last_uv;
      e.a_w = T_w_c * first_c;
      e.b_w = T_w_c * last_c;
      out.push_back(e);
    };
    for (int k = 0; k <= n; ++k) {
      const Eigen::Vector3d p = p0 + (static_cast<double>(k) / n) * (p1 - p0);
      if (SampleVisible(p, camera, depth, options, &uv)) {
        if (run_start < 0) {
          run_start = k;
          first_uv = uv;
          first_c = p;
        }
        last_uv = uv;
        last_c = p;
      } else {
        close_run();
      }
    }
    close_run();
  }
  return out;
}

}  // namespace pl_slam::sim
