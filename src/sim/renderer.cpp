#include "pl_slam/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pl_slam::sim {
namespace {

constexpr int kTile = 16;  // pixels per side of the screen tiles of the supersampling pass

// Per-view constants of one quad. For the pixel ray d = ((u - cx) / fx, (v - cy) / fy, 1) in
// the camera frame, every dot product with a camera-frame vector is affine in (u, v), so the
// per-pixel work is a handful of multiply-adds and one division.
struct QuadView {
  double num = 0.0;                     // n_c . o_c: depth = num / (n_c . d)
  double du = 0.0, dv = 0.0, d0 = 0.0;  // n_c . d = du * u + dv * v + d0
  double au = 0.0, av = 0.0, a0 = 0.0;  // axis_u_c . d
  double bu = 0.0, bv = 0.0, b0 = 0.0;  // axis_v_c . d
  double s_off = 0.0, t_off = 0.0;      // axis_u_c . o_c, axis_v_c . o_c
  double size_u = 0.0, size_v = 0.0;
  double ku = 0.0, kv = 0.0;  // texels per metre
  const Texture* texture = nullptr;
  int u_min = 0, u_max = -1, v_min = 0, v_max = -1;  // inclusive pixel bounding box

  bool InBox(int u, int v) const { return u >= u_min && u <= u_max && v >= v_min && v <= v_max; }

  // Depth of the hit at pixel (u, v), or false when the ray misses the rectangle or the hit
  // is not in front of z_near. The comparisons are written so that NaN fails them.
  bool Hit(double u, double v, double z_near, double* depth) const {
    const double lambda = num / (du * u + dv * v + d0);
    if (!(lambda > z_near)) return false;
    const double s = lambda * (au * u + av * v + a0) - s_off;
    if (!(s >= -kQuadEdgeEpsilon && s <= size_u + kQuadEdgeEpsilon)) return false;
    const double t = lambda * (bu * u + bv * v + b0) - t_off;
    if (!(t >= -kQuadEdgeEpsilon && t <= size_v + kQuadEdgeEpsilon)) return false;
    *depth = lambda;
    return true;
  }

  // Texture value seen at pixel (u, v) (the ray is known to hit). The filter footprint comes
  // from the analytic derivatives of the texture coordinates with respect to the pixel
  // coordinates: d(s, t)/du = lambda * (a_u - (a.d / n.d) * n_u) and alike, so
  // foreshortened floors are filtered along the foreshortening only.
  float Shade(double u, double v) const {
    const double inv_d = 1.0 / (du * u + dv * v + d0);
    const double lambda = num * inv_d;
    const double a = au * u + av * v + a0;
    const double b = bu * u + bv * v + b0;
    const double s = lambda * a - s_off;
    const double t = lambda * b - t_off;
    const double ra = a * inv_d;
    const double rb = b * inv_d;
    return texture->SampleFootprint(s * ku, t * kv, lambda * (au - ra * du) * ku,
                                    lambda * (bu - rb * du) * kv, lambda * (av - ra * dv) * ku,
                                    lambda * (bv - rb * dv) * kv);
  }
};

// Clips the polygon (camera frame) against z >= z_near (Sutherland-Hodgman, one plane).
std::vector<Eigen::Vector3d> ClipNear(const Eigen::Vector3d (&poly)[4], double z_near) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d& a = poly[i];
    const Eigen::Vector3d& b = poly[(i + 1) % 4];
    const bool a_in = a.z() >= z_near;
    const bool b_in = b.z() >= z_near;
    if (a_in) out.push_back(a);
    if (a_in != b_in) {
      const double w = (z_near - a.z()) / (b.z() - a.z());
      out.push_back(a + w * (b - a));
    }
  }
  return out;
}

QuadView MakeQuadView(const TexturedQuad& q, const Eigen::Matrix3d& R_c_w,
                      const Eigen::Vector3d& C_w, const StereoCamera& cam, double z_near) {
  QuadView qv;
  const Eigen::Vector3d o = R_c_w * (q.origin - C_w);
  const Eigen::Vector3d a = R_c_w * q.axis_u;
  const Eigen::Vector3d b = R_c_w * q.axis_v;
  const Eigen::Vector3d n = a.cross(b);
  const double ifx = 1.0 / cam.fx;
  const double ify = 1.0 / cam.fy;
  auto affine = [&](const Eigen::Vector3d& w, double* cu, double* cv, double* c0) {
    *cu = w.x() * ifx;
    *cv = w.y() * ify;
    *c0 = w.z() - w.x() * cam.cx * ifx - w.y() * cam.cy * ify;
  };
  qv.num = n.dot(o);
  affine(n, &qv.du, &qv.dv, &qv.d0);
  affine(a, &qv.au, &qv.av, &qv.a0);
  affine(b, &qv.bu, &qv.bv, &qv.b0);
  qv.s_off = a.dot(o);
  qv.t_off = b.dot(o);
  qv.size_u = q.size_u;
  qv.size_v = q.size_v;
  qv.ku = q.texels_per_m_u();
  qv.kv = q.texels_per_m_v();
  qv.texture = q.texture.get();

  const Eigen::Vector3d corners[4] = {o, o + q.size_u * a, o + q.size_u * a + q.size_v * b,
                                      o + q.size_v * b};
  const std::vector<Eigen::Vector3d> clipped = ClipNear(corners, z_near);
  if (clipped.empty()) return qv;  // entirely behind the camera: empty box
  double u_lo = std::numeric_limits<double>::infinity(), u_hi = -u_lo;
  double v_lo = u_lo, v_hi = -u_lo;
  for (const Eigen::Vector3d& p : clipped) {
    const Eigen::Vector2d uv = cam.Project(p);
    u_lo = std::min(u_lo, uv.x());
    u_hi = std::max(u_hi, uv.x());
    v_lo = std::min(v_lo, uv.y());
    v_hi = std::max(v_hi, uv.y());
  }
  // One pixel of margin: the exact hit test decides, the box only has to contain the quad
  // (also for the sub-pixel rays of edge supersampling).
  auto to_pixel = [](double x, int hi) {
    return static_cast<int>(std::clamp(x, -1.0, static_cast<double>(hi) + 1.0));
  };
  qv.u_min = std::max(0, to_pixel(std::floor(u_lo) - 1.0, cam.width));
  qv.u_max = std::min(cam.width - 1, to_pixel(std::ceil(u_hi) + 1.0, cam.width));
  qv.v_min = std::max(0, to_pixel(std::floor(v_lo) - 1.0, cam.height));
  qv.v_max = std::min(cam.height - 1, to_pixel(std::ceil(v_hi) + 1.0, cam.height));
  return qv;
}

}  // namespace

Renderer::Renderer(std::shared_ptr<const World> world, const StereoCamera& camera,
                   int edge_supersampling, double z_near)
    : world_(std::move(world)),
      camera_(camera),
      edge_supersampling_(edge_supersampling),
      z_near_(z_near) {
  if (!world_) throw std::invalid_argument("Renderer: world is null");
  const std::string bad = camera_.Validate();
  if (!bad.empty()) throw std::invalid_argument("Renderer: camera: " + bad);
  if (edge_supersampling_ < 1 || edge_supersampling_ > 16) {
    throw std::invalid_argument("Renderer: edge_supersampling must be in [1, 16]");
  }
  if (!(z_near_ > 0.0)) throw std::invalid_argument("Renderer: z_near must be positive");
}

RenderedView Renderer::Render(const SE3& T_w_c) const {
  const int width = camera_.width;
  const int height = camera_.height;
  const Eigen::Matrix3d R_c_w = T_w_c.rotation().transpose();
  const Eigen::Vector3d C_w = T_w_c.translation();

  const auto& quads = world_->quads();
  std::vector<QuadView> views;
  views.reserve(quads.size());
  for (const TexturedQuad& q : quads) {
    views.push_back(MakeQuadView(q, R_c_w, C_w, camera_, z_near_));
  }

  RenderedView out;
  out.radiance.create(height, width, CV_32FC1);
  out.depth.create(height, width, CV_32FC1);
  out.quad_id.create(height, width, CV_32SC1);
  const double z_near = z_near_;

  // Pass 1: visibility. Each quad is tested only inside its screen bounding box.
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    std::vector<double> best(width);
    for (int v = rows.start; v < rows.end; ++v) {
      std::fill(best.begin(), best.end(), std::numeric_limits<double>::infinity());
      int* id_row = out.quad_id.ptr<int>(v);
      std::fill(id_row, id_row + width, -1);
      for (std::size_t qi = 0; qi < views.size(); ++qi) {
        const QuadView& q = views[qi];
        if (v < q.v_min || v > q.v_max) continue;
        for (int u = q.u_min; u <= q.u_max; ++u) {
          double lambda;
          if (q.Hit(u, v, z_near, &lambda) && lambda < best[u]) {
            best[u] = lambda;
            id_row[u] = static_cast<int>(qi);
          }
        }
      }
      float* depth_row = out.depth.ptr<float>(v);
      for (int u = 0; u < width; ++u) {
        depth_row[u] = id_row[u] >= 0 ? static_cast<float>(best[u]) : 0.0f;
      }
    }
  });

  // Screen tiles listing the quads whose bounding box overlaps them, in quad order: the
  // supersampled rays of pass 2 test only those (worlds of thousands of quads, the street
  // scenes, would otherwise test every quad per ray). Same quads, same order, same result.
  const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  std::vector<int> tile_start(static_cast<std::size_t>(tiles_x) * tiles_y + 1, 0);
  auto for_tiles = [&](const QuadView& q, const auto& fn) {
    if (q.u_max < q.u_min || q.v_max < q.v_min) return;
    for (int ty = q.v_min / kTile; ty <= q.v_max / kTile; ++ty)
      for (int tx = q.u_min / kTile; tx <= q.u_max / kTile; ++tx) fn(ty * tiles_x + tx);
  };
  for (const QuadView& q : views) for_tiles(q, [&](int t) { ++tile_start[t + 1]; });
  for (std::size_t t = 1; t < tile_start.size(); ++t) tile_start[t] += tile_start[t - 1];
  std::vector<int> tile_quads(tile_start.back());
  {
    std::vector<int> fill(tile_start.begin(), tile_start.end() - 1);
    for (std::size_t qi = 0; qi < views.size(); ++qi)
      for_tiles(views[qi], [&](int t) { tile_quads[fill[t]++] = static_cast<int>(qi); });
  }

  // Pass 2: shading. Pixels whose neighbours see another quad (occlusion boundaries, room
  // corners) average k x k rays so that straight edges are not staircases.
  const int k = edge_supersampling_;
  const float background = world_->background();
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const int* id_row = out.quad_id.ptr<int>(v);
      const int* id_up = out.quad_id.ptr<int>(std::max(v - 1, 0));
      const int* id_down = out.quad_id.ptr<int>(std::min(v + 1, height - 1));
      float* rad_row = out.radiance.ptr<float>(v);
      for (int u = 0; u < width; ++u) {
        const int id = id_row[u];
        const bool edge =
            k > 1 && (id != id_up[u] || id != id_down[u] || (u > 0 && id != id_row[u - 1]) ||
                      (u + 1 < width && id != id_row[u + 1]));
        if (!edge) {
          rad_row[u] = id >= 0 ? views[id].Shade(u, v) : background;
          continue;
        }
        double sum = 0.0;
        const int tile = (v / kTile) * tiles_x + u / kTile;
        const int* first = tile_quads.data() + tile_start[tile];
        const int* last = tile_quads.data() + tile_start[tile + 1];
        for (int sy = 0; sy < k; ++sy) {
          const double y = v + (sy + 0.5) / k - 0.5;
          for (int sx = 0; sx < k; ++sx) {
            const double x = u + (sx + 0.5) / k - 0.5;
            double best = std::numeric_limits<double>::infinity();
            int best_id = -1;
            for (const int* it = first; it != last; ++it) {
              const int qi = *it;
              const QuadView& q = views[qi];
              double lambda;
              if (q.InBox(u, v) && q.Hit(x, y, z_near, &lambda) && lambda < best) {
                best = lambda;
                best_id = qi;
              }
            }
            sum += best_id >= 0 ? views[best_id].Shade(x, y) : background;
          }
        }
        rad_row[u] = static_cast<float>(sum / (k * k));
      }
    }
  });
  return out;
}

}  // namespace pl_slam::sim
