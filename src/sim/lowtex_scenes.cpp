#include "pl_slam/sim/lowtex_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pl_slam/sim/procedural_texture.h"

namespace pl_slam::sim {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Polygon = std::vector<Vec2, Eigen::aligned_allocator<Vec2>>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

constexpr double kHeight = 2.6;       // floor to ceiling, metres
constexpr double kWallTexel = 0.005;  // sharp edges down to ~0.6 m viewing distance
constexpr double kFloorTexel = 0.01;
constexpr double kEye = 1.5;       // camera height
constexpr double kGazeLead = 0.5;  // corridors: the gaze heads where the walk is 0.5 s later

// Doors: leaf 0.9 x 2.05 m in a 7 cm frame; openings 1.1 m wide, 2.1 m high.
constexpr double kDoorHalf = 0.45;
constexpr double kDoorHeight = 2.05;
constexpr double kFrame = 0.07;
constexpr double kOpeningHalf = 0.55;
constexpr double kOpeningHeight = 2.1;
constexpr double kWallThickness = 0.12;

Vec3 At(const Vec2& p, double z) { return Vec3(p.x(), p.y(), z); }

double Smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

// What a layout puts on one wall. Positions are metres along the wall from its start.
struct WallFeatures {
  std::vector<double> doors;     // closed doors (frame, leaf, handle)
  std::vector<double> switches;  // light switches, plate centre 1.1 m high
  bool baseboard = true;
  bool rail = false;         // handrail, 0.88-0.92 m high, 2-7 cm off the wall
  bool pipe = false;         // pipe 10 x 10 cm, 15-25 cm under the ceiling
  int posters = 0;           // textured variant only: small textured patches
  bool frame_start = false;  // architrave of an opening that begins at the wall's start
  bool frame_end = false;    // ... that ends at the wall's end
  // Whiteboard: centre along the wall (< 0 = none), 1.8 x 1.1 m, centre 1.45 m high.
  double whiteboard = -1.0;
  // Textured variant: 0.6 x 0.5 m posters centred here (top 1.75 m high).
  std::vector<double> posters_at;
  // Extra light switch centres with their height (plate centre), e.g. beside a camera's target.
  std::vector<std::pair<double, double>> switches_at;
};

// Builds one lowtex world: quads, structural edges and layout randomness.
class Builder {
 public:
  Builder(uint64_t seed, bool bare) : world_(std::make_shared<World>()), seed_(seed), bare_(bare) {}

  World* world() { return world_.get(); }
  std::shared_ptr<const World> Take() { return std::move(world_); }
  // A fresh, reproducible seed per surface (in creation order).
  uint64_t Tag() { return MixSeed(seed_, next_tag_++); }

  void Edge(const Vec3& a, const Vec3& b) { world_->AddStructuralEdge(a, b); }

  void Quad(const Vec3& corner, const Vec3& edge_u, const Vec3& edge_v,
            std::shared_ptr<const Texture> texture) {
    world_->AddQuad(MakeQuad(corner, edge_u, edge_v, std::move(texture)));
  }

  // A closed loop of floor-to-ceiling walls; the walkable inside is on the walls' left when
  // interior_left (counter-clockwise loop), else on their right. Structural edges: every
  // wall's floor and ceiling line and every vertical room corner (up to vertex_top[i] when
  // given, e.g. the jambs of an opening end under its lintel).
  void Loop(const Polygon& poly, const std::vector<WallFeatures>& features, bool interior_left,
            const std::vector<double>& vertex_top = {}) {
    const std::size_t n = poly.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2& a = poly[i];
      const Vec2& b = poly[(i + 1) % n];
      Wall(a, b, interior_left, features[i]);
      Edge(At(a, 0.0), At(b, 0.0));
      Edge(At(a, kHeight), At(b, kHeight));
      Edge(At(a, 0.0), At(a, vertex_top.empty() ? kHeight : vertex_top[i]));
    }
  }

  // Floor and ceiling over the rectangle [lo, hi] (walls hide what lies outside the loop).
  void FloorAndCeiling(const Vec2& lo, const Vec2& hi) {
    const double w = hi.x() - lo.x(), d = hi.y() - lo.y();
    const Vec3 eu(w, 0, 0), ev(0, d, 0);
    if (bare_) {
      TextureCanvas floor(w, d, kFloorTexel, 104);
      Quad(At(lo, 0.0), eu, ev, FinishPlain(floor, kFloorTexel, 0.05, Tag(), lo.x()));
    } else {
      Quad(At(lo, 0.0), eu, ev,
           MakeSurfaceTexture(SurfaceStyle::kFloorTiles, w, d, kFloorTexel, 116, Tag()));
    }
    TextureCanvas ceiling(w, d, kFloorTexel, 206);
    if (!bare_) {
      // Suspended ceiling: 0.6 m grid, a 0.6 x 1.2 m light panel in every fourth column.
      const double cell = 0.6;
      for (double x = cell; x < w; x += cell) ceiling.Line({x, 0}, {x, d}, 0.01, 172);
      for (double y = cell; y < d; y += cell) ceiling.Line({0, y}, {w, y}, 0.01, 172);
      for (int i = 1; (i + 1) * cell < w; i += 4) {
        for (int j = 1; (j + 2) * cell < d; j += 4) {
          ceiling.FillRect(i * cell, j * cell, (i + 1) * cell, (j + 2) * cell, 252);
          ceiling.FrameRect(i * cell, j * cell, (i + 1) * cell, (j + 2) * cell, 0.015, 160);
        }
      }
    }
    Quad(At(lo, kHeight), eu, ev, FinishPlain(ceiling, kFloorTexel, 0.04, Tag(), lo.x()));
  }

  // A plain box (desk, cabinet) standing on the floor, with its 12 edges (the 4 on the floor
  // included: it stands on a floor of another grey).
  void Box(const Vec3& lo, const Vec3& hi, double grey) {
    const double dx = hi.x() - lo.x(), dy = hi.y() - lo.y(), dz = hi.z() - lo.z();
    const Vec3 down(0, 0, -dz);
    const double shade[5] = {0, -10, 8, -16, 18};
    int face = 0;
    auto plain = [&](double w, double h) {
      TextureCanvas c(w, h, 0.01, grey + shade[face++]);
      return FinishPlain(c, 0.01, 0.0, Tag());
    };
    Quad({lo.x(), lo.y(), hi.z()}, {dx, 0, 0}, down, plain(dx, dz));
    Quad({hi.x(), hi.y(), hi.z()}, {-dx, 0, 0}, down, plain(dx, dz));
    Quad({lo.x(), hi.y(), hi.z()}, {0, -dy, 0}, down, plain(dy, dz));
    Quad({hi.x(), lo.y(), hi.z()}, {0, dy, 0}, down, plain(dy, dz));
    Quad({lo.x(), lo.y(), hi.z()}, {dx, 0, 0}, {0, dy, 0}, plain(dx, dy));
    const Vec3 c[4] = {
        {lo.x(), lo.y(), 0}, {hi.x(), lo.y(), 0}, {hi.x(), hi.y(), 0}, {lo.x(), hi.y(), 0}};
    for (int i = 0; i < 4; ++i) {
      const Vec3 a = c[i], b = c[(i + 1) % 4];
      const Vec3 up(0, 0, hi.z());
      Edge(a + Vec3(0, 0, lo.z()), b + Vec3(0, 0, lo.z()));
      Edge(a + up, b + up);
      Edge(a + Vec3(0, 0, lo.z()), a + up);
    }
  }

  // A shelf unit against a wall: back panel, two sides, top and shelf boards (with their
  // front strips). `origin` is the unit's bottom-left corner on the wall seen from the room,
  // u runs along the wall, n into the room. Textured: a row of books on each board.
  void Shelf(const Vec2& origin, const Vec2& u, const Vec2& n, double width, double depth,
             double height, int boards, double grey) {
    auto plain = [&](double w, double h, double g) {
      TextureCanvas c(w, h, 0.005, g);
      return FinishPlain(c, 0.005, 0.0, Tag());
    };
    const Vec3 U = At(u, 0) * width, N = At(n, 0) * depth, up(0, 0, height);
    const Vec3 o = At(origin + 0.01 * n, 0.0);
    // Back panel (1 cm off the wall), sides.
    Quad(o + up, U, -up, plain(width, height, grey - 18));
    Quad(o + up, N, -up, plain(depth, height, grey - 8));
    Quad(o + U + up, N, -up, plain(depth, height, grey - 8));
    Edge(o + N, o + N + up);
    Edge(o + U + N, o + U + N + up);
    Edge(o, o + up);
    Edge(o + U, o + U + up);
    for (int k = 0; k <= boards; ++k) {
      const double z = k == boards ? height : 0.08 + (height - 0.2) * k / boards;
      const Vec3 zb(0, 0, z);
      Quad(o + zb, U, N, plain(width, depth, grey + 14));  // board top
      const Vec3 strip(0, 0, 0.022);
      Quad(o + N + zb, U, -strip, plain(width, 0.022, grey - 4));  // front strip
      Edge(o + N + zb, o + U + N + zb);
      Edge(o + N + zb - strip, o + U + N + zb - strip);
      Edge(o + zb, o + U + zb);
      if (!bare_ && k < boards) {
        // Book spines 7 cm in front of the back panel, 75 % of the way up to the next board.
        const double next = (k + 1 == boards) ? height : 0.08 + (height - 0.2) * (k + 1) / boards;
        const double h = 0.75 * (next - z - 0.022);
        const double w = width * 0.86;
        Quad(o + 0.07 * U + 0.06 * At(n, 0) + zb + Vec3(0, 0, h), At(u, 0) * w, Vec3(0, 0, -h),
             MakeSurfaceTexture(SurfaceStyle::kClutter, w, h, 0.004, 120, Tag()));
      }
    }
  }

  // The texture of a drawn canvas with a smooth light gradient (never texture): brightness
  // varies by +-`along` with a 3.4 m period along x and falls by 6 % from ceiling to floor,
  // plus sub-noise grain (0.6 grey levels per texel). x_offset_m is the canvas's x = 0 in a
  // coordinate shared by coplanar surfaces and y_top_m its row 0's depth under the ceiling,
  // so that adjoining pieces of one wall (a wall and a lintel) shade seamlessly.
  std::shared_ptr<const Texture> FinishPlain(const TextureCanvas& c, double texel_m, double along,
                                             uint64_t seed, double x_offset_m = 0.0,
                                             double y_top_m = 0.0) {
    cv::Mat f;
    c.albedo().convertTo(f, CV_32F);
    std::vector<float> gx(f.cols);
    for (int x = 0; x < f.cols; ++x) {
      gx[x] = static_cast<float>(
          1.0 + along * std::cos(2 * kPi * (x_offset_m + (x + 0.5) * texel_m) / 3.4));
    }
    for (int y = 0; y < f.rows; ++y) {
      const float gy = static_cast<float>(1.0 - 0.06 * (y_top_m + (y + 0.5) * texel_m) / kHeight);
      float* row = f.ptr<float>(y);
      for (int x = 0; x < f.cols; ++x) row[x] *= gx[x] * gy;
    }
    cv::RNG rng(seed);
    cv::Mat grain(f.size(), CV_32F);
    rng.fill(grain, cv::RNG::NORMAL, 0.0, 0.6);
    f += grain;
    return std::make_shared<Texture>(f);
  }

  // The grey of a wall whose room side faces n_in: walls facing different ways differ
  // (directional light), so room corners show.
  static double WallGrey(const Vec2& n_in) {
    return 168.0 + 20.0 * std::cos(std::atan2(n_in.y(), n_in.x()) - 20.0 * kDeg);
  }

 private:
  // One floor-to-ceiling wall from a to b with its features. Canvas coordinates: x metres
  // along the wall from a, y metres down from the ceiling.
  void Wall(const Vec2& a, const Vec2& b, bool interior_left, const WallFeatures& f) {
    const double length = (b - a).norm();
    const Vec2 u = (b - a) / length;
    const Vec2 n_in = (interior_left ? 1.0 : -1.0) * Vec2(-u.y(), u.x());
    const double grey = WallGrey(n_in);
    auto P = [&](double x, double y) { return At(a + x * u, kHeight - y); };
    auto E = [&](double x0, double y0, double x1, double y1) { Edge(P(x0, y0), P(x1, y1)); };
    const double h = kHeight;
    cv::RNG rng(Tag());
    TextureCanvas c(length, h, kWallTexel, grey);

    // Spans blocked by door frames and opening architraves (for baseboard, seams, rail).
    std::vector<std::pair<double, double>> blocked;
    for (double d : f.doors) blocked.emplace_back(d - kDoorHalf - kFrame, d + kDoorHalf + kFrame);
    if (f.frame_start) blocked.emplace_back(-1.0, kFrame);
    if (f.frame_end) blocked.emplace_back(length - kFrame, length + 1.0);
    auto free_spans = [&](double margin) {
      std::vector<std::pair<double, double>> spans;
      std::vector<std::pair<double, double>> sorted = blocked;
      std::sort(sorted.begin(), sorted.end());
      double x = 0.0;
      for (const auto& [lo, hi] : sorted) {
        if (lo - margin > x) spans.emplace_back(x, lo - margin);
        x = std::max(x, hi + margin);
      }
      if (x < length) spans.emplace_back(x, length);
      return spans;
    };
    auto is_free = [&](double x0, double x1) {
      for (const auto& [lo, hi] : blocked)
        if (x1 > lo && x0 < hi) return false;
      return true;
    };

    if (!bare_) {  // panel seams every 1.25 m
      for (double x = 1.25; x < length - 0.2; x += 1.25) {
        if (is_free(x - 0.3, x + 0.3)) c.Line({x, 0.0}, {x, h - 0.1}, 0.003, grey - 16);
      }
    }
    if (f.baseboard) {
      for (const auto& [x0, x1] : free_spans(0.0)) {
        c.FillRect(x0, h - 0.1, x1, h, 88);
        E(x0, h - 0.1, x1, h - 0.1);
      }
    }
    for (double d : f.doors) {
      const double top = h - kDoorHeight;
      const double frame_grey = grey * 0.8;
      c.FillRect(d - kDoorHalf - kFrame, top - kFrame, d + kDoorHalf + kFrame, h, frame_grey);
      c.FillRect(d - kDoorHalf, top, d + kDoorHalf, h, rng.uniform(105.0, 145.0));
      c.FillRect(d + kDoorHalf - 0.15, h - 1.03, d + kDoorHalf - 0.05, h - 0.99, 55);  // handle
      E(d - kDoorHalf - kFrame, h, d - kDoorHalf - kFrame, top - kFrame);
      E(d + kDoorHalf + kFrame, h, d + kDoorHalf + kFrame, top - kFrame);
      E(d - kDoorHalf - kFrame, top - kFrame, d + kDoorHalf + kFrame, top - kFrame);
      E(d - kDoorHalf, h, d - kDoorHalf, top);
      E(d + kDoorHalf, h, d + kDoorHalf, top);
      E(d - kDoorHalf, top, d + kDoorHalf, top);
    }
    const double arch_top = h - kOpeningHeight - kFrame;
    if (f.frame_start) {
      c.FillRect(0.0, arch_top, kFrame, h, grey * 0.8);
      E(kFrame, h, kFrame, arch_top);
    }
    if (f.frame_end) {
      c.FillRect(length - kFrame, arch_top, length, h, grey * 0.8);
      E(length - kFrame, h, length - kFrame, arch_top);
    }
    std::vector<std::pair<double, double>> switches = f.switches_at;
    for (double s : f.switches) switches.emplace_back(s, 1.1);
    for (const auto& [s, z] : switches) {
      const double y0 = h - z - 0.06, y1 = h - z + 0.06;
      c.FillRect(s - 0.04, y0, s + 0.04, y1, std::min(250.0, grey + 35.0));
      c.FillRect(s - 0.012, y0 + 0.04, s + 0.012, y1 - 0.04, grey - 10);  // rocker
      E(s - 0.04, y0, s + 0.04, y0);
      E(s - 0.04, y1, s + 0.04, y1);
      E(s - 0.04, y0, s - 0.04, y1);
      E(s + 0.04, y0, s + 0.04, y1);
    }
    if (f.whiteboard >= 0.0) {
      const double x0 = f.whiteboard - 0.9, x1 = f.whiteboard + 0.9;
      const double y0 = h - 1.45 - 0.55, y1 = h - 1.45 + 0.55;
      c.FillRect(x0, y0, x1, y1, 120);
      c.FillRect(x0 + 0.025, y0 + 0.025, x1 - 0.025, y1 - 0.025, 238);
      c.FillRect(x0 + 0.3, y1, x1 - 0.3, y1 + 0.04, 110);  // pen tray
      E(x0, y0, x1, y0);
      E(x0, y1, x1, y1);
      E(x0, y0, x0, y1);
      E(x1, y0, x1, y1);
      E(x0 + 0.025, y0 + 0.025, x1 - 0.025, y0 + 0.025);
      E(x0 + 0.025, y1 - 0.025, x1 - 0.025, y1 - 0.025);
      E(x0 + 0.025, y0 + 0.025, x0 + 0.025, y1 - 0.025);
      E(x1 - 0.025, y0 + 0.025, x1 - 0.025, y1 - 0.025);
    }
    Quad(At(a, h), At(b - a, 0.0), Vec3(0, 0, -h),
         FinishPlain(c, kWallTexel, 0.05, rng.next(), a.dot(u)));

    const Vec3 N = At(n_in, 0.0), U = At(u, 0.0);
    if (!bare_) {
      std::vector<std::pair<double, double>> poster_spans;
      for (int k = 0; k < f.posters; ++k) {
        for (int attempt = 0; attempt < 20; ++attempt) {
          const double w = rng.uniform(0.45, 0.8), ph = rng.uniform(0.4, 0.7);
          if (length < w + 0.6) break;
          const double x0 = rng.uniform(0.3, length - w - 0.3);
          bool clash = !is_free(x0 - 0.1, x0 + w + 0.1);
          for (const auto& [lo, hi] : poster_spans) clash = clash || (x0 + w > lo && x0 < hi);
          for (const auto& [s, z] : switches) clash = clash || (s > x0 - 0.15 && s < x0 + w + 0.15);
          if (clash) continue;
          const double top = rng.uniform(1.65, 1.95);
          Quad(At(a + x0 * u, top) + 0.004 * N, w * U, Vec3(0, 0, -ph),
               MakeSurfaceTexture(SurfaceStyle::kClutter, w, ph, 0.004, rng.uniform(130.0, 170.0),
                                  rng.next()));
          poster_spans.emplace_back(x0 - 0.2, x0 + w + 0.2);
          break;
        }
      }
    }
    if (!bare_) {
      for (double x : f.posters_at) {
        Quad(At(a + (x - 0.3) * u, 1.75) + 0.004 * N, 0.6 * U, Vec3(0, 0, -0.5),
             MakeSurfaceTexture(SurfaceStyle::kClutter, 0.6, 0.5, 0.004, 150, rng.next()));
      }
    }
    auto plain = [&](double w, double hh, double g) {
      TextureCanvas pc(w, hh, 0.01, g);
      return FinishPlain(pc, 0.01, 0.0, rng.next());
    };
    if (f.rail) {
      for (const auto& [x0, x1] : free_spans(0.08)) {
        if (x1 - x0 < 0.4) continue;
        const Vec3 o = At(a + x0 * u, 0.92), L = (x1 - x0) * U;
        const Vec3 off = 0.02 * N, depth = 0.05 * N, zc(0, 0, 0.04);
        Quad(o + off + depth, L, -zc, plain(x1 - x0, 0.04, 80));  // front
        Quad(o + off, L, depth, plain(x1 - x0, 0.05, 96));        // top
        Quad(o + off - zc, L, depth, plain(x1 - x0, 0.05, 66));   // bottom
        Quad(o + off, depth, -zc, plain(0.05, 0.04, 74));         // end caps
        Quad(o + off + L, depth, -zc, plain(0.05, 0.04, 74));
        Edge(o + off + depth, o + off + depth + L);
        Edge(o + off + depth - zc, o + off + depth - zc + L);
        Edge(o + off, o + off + L);
      }
    }
    if (f.pipe) {
      const Vec3 o = At(a, kHeight - 0.15), L = length * U;
      const Vec3 off = 0.05 * N, depth = 0.1 * N, zc(0, 0, 0.1);
      Quad(o + off + depth, L, -zc, plain(length, 0.1, 212));  // front
      Quad(o + off - zc, L, depth, plain(length, 0.1, 188));   // bottom
      Quad(o + off, L, -zc, plain(length, 0.1, 200));          // back
      Edge(o + off + depth, o + off + depth + L);
      Edge(o + off + depth - zc, o + off + depth - zc + L);
      Edge(o + off - zc, o + off - zc + L);
    }
  }

  std::shared_ptr<World> world_;
  uint64_t seed_;
  bool bare_;
  uint64_t next_tag_ = 1000;
};

// Doors along a wall of the given length: first 1.2-2.7 m from its start, then every 3-4.5 m,
// none closer than 1.2 m to its end; a light switch beside about half of them.
void AutoDoors(double length, cv::RNG& rng, WallFeatures* f) {
  for (double x = 1.2 + rng.uniform(0.0, 1.5); x < length - 1.2; x += rng.uniform(3.0, 4.5)) {
    f->doors.push_back(x);
    if (rng.uniform(0, 2) == 0) {
      const double s = x + (rng.uniform(0, 2) ? 0.75 : -0.75);
      if (s > 0.2 && s < length - 0.2) f->switches.push_back(s);
    }
  }
}

// Adds `count` posters to walls of length >= 2.5 m, chosen at random.
void AutoPosters(const Polygon& poly, int count, cv::RNG& rng, std::vector<WallFeatures>* f) {
  std::vector<int> candidates;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    if ((poly[(i + 1) % poly.size()] - poly[i]).norm() >= 2.5) candidates.push_back(i);
  }
  for (int k = 0; k < count && !candidates.empty(); ++k) {
    (*f)[candidates[rng.uniform(0, static_cast<int>(candidates.size()))]].posters++;
  }
}

void BoundingBox(const Polygon& poly, Vec2* lo, Vec2* hi) {
  *lo = poly[0];
  *hi = poly[0];
  for (const Vec2& p : poly) {
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
  }
  *lo -= Vec2(0.5, 0.5);
  *hi += Vec2(0.5, 0.5);
}

// The walls of a corridor of half-width `half` around an open polyline, as a
// counter-clockwise loop: the right-hand side forward, the far end, the left-hand side back,
// the near end. right_edges / left_edges receive the loop indices of the side walls.
Polygon CorridorLoop(const Polygon& centre, double half, std::vector<int>* right_edges,
                     std::vector<int>* left_edges) {
  const std::size_t n = centre.size();
  auto offset = [&](double side) {  // side +1 = left
    Polygon out;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2 d_in = (centre[i > 0 ? i : 1] - centre[i > 0 ? i - 1 : 0]).normalized();
      const Vec2 d_out =
          (centre[i + 1 < n ? i + 1 : n - 1] - centre[i + 1 < n ? i : n - 2]).normalized();
      const Vec2 n_in(-d_in.y(), d_in.x()), n_out(-d_out.y(), d_out.x());
      // Miter: the point at distance `half` from both adjoining centre segments.
      out.push_back(centre[i] + side * half * (n_in + n_out) / (1.0 + n_in.dot(n_out)));
    }
    return out;
  };
  const Polygon right = offset(-1.0), left = offset(1.0);
  Polygon loop;
  for (std::size_t i = 0; i < n; ++i) loop.push_back(right[i]);
  for (std::size_t i = n; i-- > 0;) loop.push_back(left[i]);
  for (std::size_t i = 0; i + 1 < n; ++i) right_edges->push_back(static_cast<int>(i));
  for (std::size_t i = 0; i + 1 < n; ++i) left_edges->push_back(static_cast<int>(n + i));
  return loop;
}

// A walk along straight legs joined by circular arcs of the given radius.
class Path2D {
 public:
  Path2D(const Polygon& waypoints, double radius) {
    Vec2 cur = waypoints[0];
    for (std::size_t i = 1; i < waypoints.size(); ++i) {
      const Vec2 d_in = (waypoints[i] - waypoints[i - 1]).normalized();
      const double h_in = std::atan2(d_in.y(), d_in.x());
      if (i + 1 == waypoints.size()) {
        Add(cur, h_in, (waypoints[i] - cur).norm(), 0.0);
        break;
      }
      const Vec2 d_out = (waypoints[i + 1] - waypoints[i]).normalized();
      const double phi = std::atan2(d_in.x() * d_out.y() - d_in.y() * d_out.x(), d_in.dot(d_out));
      const double t = radius * std::tan(std::abs(phi) / 2);
      const Vec2 arc_start = waypoints[i] - t * d_in;
      Add(cur, h_in, (arc_start - cur).norm(), 0.0);
      Add(arc_start, h_in, radius * std::abs(phi), (phi > 0 ? 1.0 : -1.0) / radius);
      cur = waypoints[i] + t * d_out;
    }
  }

  double length() const { return pieces_.back().s0 + pieces_.back().len; }

  Vec2 Position(double s) const {
    const Piece& p = Find(s);
    const double r = std::clamp(s - p.s0, 0.0, p.len);
    if (p.k == 0.0) return p.p0 + r * Vec2(std::cos(p.h0), std::sin(p.h0));
    const double h = p.h0 + p.k * r;
    return p.p0 + Vec2(std::sin(h) - std::sin(p.h0), std::cos(p.h0) - std::cos(h)) / p.k;
  }

  double Heading(double s) const {
    const Piece& p = Find(s);
    return p.h0 + p.k * std::clamp(s - p.s0, 0.0, p.len);
  }

  // Distance along the path from s to the nearest arc (0 on one).
  double DistanceToTurn(double s) const {
    double best = 1e9;
    for (const Piece& p : pieces_) {
      if (p.k == 0.0) continue;
      best = std::min(best, std::max({0.0, p.s0 - s, s - (p.s0 + p.len)}));
    }
    return best;
  }

 private:
  struct Piece {
    Vec2 p0;
    double h0, s0, len, k;  // start heading, start arc length, length, curvature
  };
  void Add(const Vec2& p0, double h0, double len, double k) {
    const double s0 = pieces_.empty() ? 0.0 : pieces_.back().s0 + pieces_.back().len;
    pieces_.push_back({p0, h0, s0, std::max(0.0, len), k});
  }
  const Piece& Find(double s) const {
    for (const Piece& p : pieces_)
      if (s < p.s0 + p.len) return p;
    return pieces_.back();
  }
  std::vector<Piece> pieces_;
};

// Arc length walked at each time step of a walk: `speed` m/s on straight legs, `turn_speed`
// on arcs (blended over 1.2 m), starting at 35 % speed and easing to a stop at the end.
class WalkTiming {
 public:
  WalkTiming(const Path2D& path, double speed, double turn_speed) {
    s_.push_back(0.0);
    double s = 0.0;
    while (s < path.length()) {
      const double turn = Smoothstep(path.DistanceToTurn(s) / 1.2);
      double v = turn_speed + (speed - turn_speed) * turn;
      v *= 0.35 + 0.65 * Smoothstep(s / 1.0);
      v *= 0.25 + 0.75 * Smoothstep((path.length() - s) / 0.8);
      s = std::min(path.length(), s + v * kDt);
      s_.push_back(s);
    }
  }
  double duration() const { return (s_.size() - 1) * kDt; }
  double ArcLength(double t) const {
    const double x = std::clamp(t / kDt, 0.0, static_cast<double>(s_.size() - 1));
    const std::size_t i = std::min(static_cast<std::size_t>(x), s_.size() - 2);
    return s_[i] + (x - i) * (s_[i + 1] - s_[i]);
  }

 private:
  static constexpr double kDt = 0.002;
  std::vector<double> s_;
};

// Keyframed motion (time, x, y, yaw) with cubic Hermite interpolation: tangents by central
// differences in time (continuous velocity), zero at keys marked `stop` and at both ends.
struct Key {
  double t, x, y, yaw;
  bool stop = false;
};

class KeyedMotion {
 public:
  explicit KeyedMotion(std::vector<Key> keys) : k_(std::move(keys)) {}
  double duration() const { return k_.back().t; }
  // (x, y, yaw) at time t (held before the first and after the last key).
  Eigen::Vector3d At(double t) const {
    if (t <= k_.front().t) return Value(0);
    if (t >= k_.back().t) return Value(k_.size() - 1);
    std::size_t i = 0;
    while (k_[i + 1].t <= t) ++i;
    const double dt = k_[i + 1].t - k_[i].t, u = (t - k_[i].t) / dt;
    const double h00 = 2 * u * u * u - 3 * u * u + 1, h10 = u * u * u - 2 * u * u + u;
    const double h01 = -2 * u * u * u + 3 * u * u, h11 = u * u * u - u * u;
    return h00 * Value(i) + h10 * dt * Tangent(i) + h01 * Value(i + 1) + h11 * dt * Tangent(i + 1);
  }

 private:
  Eigen::Vector3d Value(std::size_t i) const { return {k_[i].x, k_[i].y, k_[i].yaw}; }
  Eigen::Vector3d Tangent(std::size_t i) const {
    if (i == 0 || i + 1 == k_.size() || k_[i].stop) return Eigen::Vector3d::Zero();
    return (Value(i + 1) - Value(i - 1)) / (k_[i + 1].t - k_[i - 1].t);
  }
  std::vector<Key> k_;
};

// A pose from walking-camera motion: position on the floor plan, yaw, and the small head
// motion of a hand-held camera (step bob, pitch and roll wobble).
SE3 WalkingPose(const Vec2& p, double yaw, double t, double pitch0 = 0.03) {
  const double z = kEye + 0.015 * std::sin(2 * kPi * 1.8 * t);
  const double pitch = pitch0 + 0.02 * std::sin(2 * kPi * t / 4.3 + 0.7);
  const double roll = 0.012 * std::sin(2 * kPi * 0.9 * t);
  return CameraPoseFromYawPitchRoll(At(p, z), yaw, pitch, roll);
}

// What a layout builder returns: the world and the camera motion (pose at time t) with its
// duration.
struct Layout {
  std::shared_ptr<const World> world;
  std::function<SE3(double)> pose;
  double duration = 0.0;
};

// Walks a Path2D with the gaze leading the walk, plus lateral and yaw sway.
Layout PathLayout(Builder* b, std::shared_ptr<const Path2D> path, double speed, double turn_speed,
                  double yaw_sway, double side_sway, bool build_world) {
  auto timing = std::make_shared<WalkTiming>(*path, speed, turn_speed);
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = timing->duration();
  l.pose = [path, timing, yaw_sway, side_sway](double t) {
    const double s = timing->ArcLength(t);
    const double h = path->Heading(s);
    const Vec2 side(-std::sin(h), std::cos(h));
    const Vec2 p = path->Position(s) + side_sway * std::sin(2 * kPi * t / 6.5) * side;
    const double yaw = path->Heading(timing->ArcLength(t + kGazeLead)) +
                       yaw_sway * std::sin(2 * kPi * t / 5.5 + 0.4);
    return WalkingPose(p, yaw, t);
  };
  return l;
}

// lowtex_corner: a Z-shaped corridor (two 90-degree corners, the middle leg to the left or
// right), walked along its centre with the gaze leading.
Layout CornerLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double a = rng.uniform(5.0, 6.5), mid = rng.uniform(3.5, 5.0), c = rng.uniform(4.5, 6.0);
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const Polygon centre = {{-1.2, 0.0}, {a, 0.0}, {a, side * mid}, {a + c, side * mid}};
  auto path = std::make_shared<Path2D>(
      Polygon{{0.0, 0.0}, {a, 0.0}, {a, side * mid}, {a + c - 1.6, side * mid}}, 1.0);
  if (build_world) {
    std::vector<int> right, left;
    const Polygon loop = CorridorLoop(centre, 1.0, &right, &left);
    std::vector<WallFeatures> f(loop.size());
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const double len = (loop[(i + 1) % loop.size()] - loop[i]).norm();
      if (len > 3.0) AutoDoors(len, rng, &f[i]);
    }
    for (int i : right) f[i].rail = true;
    for (int i : left) f[i].pipe = true;
    f[3].doors = {1.0};  // far end
    f[7].doors = {1.0};  // near end, behind the start
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.25, 0.85, 0.03, 0.05, build_world);
}

// lowtex_straight: a straight corridor, walked with the gaze swaying to the doors.
Layout StraightLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double walk = rng.uniform(11.0, 13.0);
  const Polygon centre = {{-1.2, 0.0}, {walk + 2.0, 0.0}};
  auto path = std::make_shared<Path2D>(Polygon{{0.0, 0.0}, {walk, 0.0}}, 1.0);
  if (build_world) {
    std::vector<int> right, left;
    const Polygon loop = CorridorLoop(centre, 1.0, &right, &left);
    std::vector<WallFeatures> f(loop.size());
    AutoDoors((loop[1] - loop[0]).norm(), rng, &f[0]);
    AutoDoors((loop[3] - loop[2]).norm(), rng, &f[2]);
    f[rng.uniform(0, 2) ? 0 : 2].rail = true;
    f[rng.uniform(0, 2) ? 0 : 2].pipe = true;
    f[1].doors = {1.0};
    f[3].doors = {1.0};
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.3, 1.3, 0.12, 0.12, build_world);
}

// lowtex_spin: walks into the 3.2 x 3.2 m hub of a four-way junction, turns 270 degrees on
// the spot (left or right) and walks out along the branch then ahead.
Layout SpinLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const double west = rng.uniform(4.2, 5.0), east = rng.uniform(3.5, 4.5);
  const double out_arm = rng.uniform(4.8, 5.5), other_arm = rng.uniform(3.5, 4.5);
  // Walking out toward -y after a left turn (+270 deg), +y after a right one.
  const double south = side > 0 ? out_arm : other_arm, north = side > 0 ? other_arm : out_arm;
  if (build_world) {
    const double w = 1.0, hub = 1.6;
    const Polygon loop = {{-west, -w}, {-hub, -w}, {-hub, -hub}, {-w, -hub}, {-w, -south},
                          {w, -south}, {w, -hub},  {hub, -hub},  {hub, -w},  {east, -w},
                          {east, w},   {hub, w},   {hub, hub},   {w, hub},   {w, north},
                          {-w, north}, {-w, hub},  {-hub, hub},  {-hub, w},  {-west, w}};
    std::vector<WallFeatures> f(loop.size());
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const double len = (loop[(i + 1) % loop.size()] - loop[i]).norm();
      if (len > 3.0) AutoDoors(len, rng, &f[i]);
      if (len < 1.0) f[i].switches = {len / 2};  // hub walls
    }
    f[4].doors = {1.0};
    f[9].doors = {1.0};
    f[14].doors = {1.0};
    f[19].doors = {1.0};
    f[0].rail = f[8].rail = true;
    f[18].pipe = f[3].pipe = true;
    AutoPosters(loop, 4, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  const double s = side, deg = kDeg;
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, -3.2, 0.0, 0.0, true},
      {1.5, -2.1, 0.0, 0.0},
      {3.2, -0.35, 0.02, 0.0},
      {4.3, 0.0, 0.0, s * 15 * deg},
      {5.3, 0.05, 0.03, s * 62 * deg},
      {6.3, 0.06, -0.02, s * 138 * deg},
      {7.3, 0.0, -0.03, s * 212 * deg},
      {8.3, 0.0, 0.0, s * 255 * deg},
      {9.1, 0.0, -s * 0.3, s * 270 * deg},
      {10.5, 0.0, -s * 1.8, s * 270 * deg},
      {11.8, 0.0, -s * 3.0, s * 270 * deg, true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d m = motion->At(t);
    return WalkingPose(m.head<2>(), m.z(), t);
  };
  return l;
}

// lowtex_doorway: along a corridor, through a doorway (1.1 m opening in a 12 cm wall) into a
// plain room, across it and a turn to one side.
Layout DoorwayLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;  // door in the left or right wall
  const double dx = rng.uniform(4.0, 5.0), corridor_end = dx + rng.uniform(3.5, 5.0);
  const double room_w = rng.uniform(4.5, 5.5), room_d = rng.uniform(4.2, 5.0);
  const double rx0 = dx - room_w / 2 + rng.uniform(-0.5, 0.5), rx1 = rx0 + room_w;
  const double y1 = 1.0, y2 = 1.0 + kWallThickness, y3 = y2 + room_d;
  // In the room the walk turns to its wider side.
  const double end_x =
      rx1 - dx > dx - rx0 ? std::min(dx + 2.0, rx1 - 1.2) : std::max(dx - 2.0, rx0 + 1.2);
  auto mirror = [side](Vec2 p) { return Vec2(p.x(), side * p.y()); };
  const double yc = y2 + room_d / 2 + 0.2;
  auto path = std::make_shared<Path2D>(
      Polygon{mirror({0.0, 0.0}), mirror({dx, 0.0}), mirror({dx, yc}), mirror({end_x, yc})}, 0.9);
  if (build_world) {
    const double o0 = dx - kOpeningHalf, o1 = dx + kOpeningHalf;
    Polygon loop = {{-1.2, -1.0},       {corridor_end, -1.0},
                    {corridor_end, y1}, {o1, y1},
                    {o1, y2},           {rx1, y2},
                    {rx1, y3},          {rx0, y3},
                    {rx0, y2},          {o0, y2},
                    {o0, y1},           {-1.2, y1}};
    for (Vec2& p : loop) p = mirror(p);
    std::vector<WallFeatures> f(loop.size());
    AutoDoors((loop[1] - loop[0]).norm(), rng, &f[0]);
    f[0].rail = true;
    f[1].doors = {1.0};
    f[2].frame_end = f[4].frame_start = f[8].frame_end = f[10].frame_start = true;
    f[2].pipe = f[10].pipe = true;
    f[4].switches = {0.35};
    f[6].doors = {room_w * rng.uniform(0.25, 0.75)};
    f[11].doors = {1.0};
    AutoPosters(loop, 3, rng, &f);
    std::vector<double> top(loop.size(), kHeight);
    top[3] = top[4] = top[9] = top[10] = kOpeningHeight;  // jambs end under the lintel
    b->Loop(loop, f, side > 0, top);
    // Lintel over the opening: both faces (continuing the adjoining walls, with the
    // architrave along the bottom) and the soffit.
    const double lh = kHeight - kOpeningHeight;
    for (double y : {y1, y2}) {
      const Vec2 n_in = mirror({0.0, y == y1 ? -1.0 : 1.0});
      const double grey = Builder::WallGrey(n_in);
      TextureCanvas face(2 * kOpeningHalf, lh, kWallTexel, grey);
      face.FillRect(0.0, lh - kFrame, 2 * kOpeningHalf, lh, grey * 0.8);
      b->Quad(At(mirror({o0, y}), kHeight), Vec3(2 * kOpeningHalf, 0, 0), Vec3(0, 0, -lh),
              b->FinishPlain(face, kWallTexel, 0.05, b->Tag(), o0));
      b->Edge(At(mirror({o0 - kFrame, y}), kOpeningHeight + kFrame),
              At(mirror({o1 + kFrame, y}), kOpeningHeight + kFrame));
      b->Edge(At(mirror({o0, y}), kOpeningHeight), At(mirror({o1, y}), kOpeningHeight));
    }
    TextureCanvas soffit(2 * kOpeningHalf, kWallThickness, kWallTexel, 150);
    const Vec2 s0 = mirror({o0, y1}), s1 = mirror({o0, y2});
    b->Quad(At(s0, kOpeningHeight), Vec3(2 * kOpeningHalf, 0, 0), At(s1 - s0, 0.0),
            b->FinishPlain(soffit, kWallTexel, 0.0, b->Tag()));
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.2, 0.8, 0.03, 0.03, build_world);
}

// lowtex_wall: in a plain room, walks up to a bare wall until it fills the view at 0.6-0.8 m,
// then turns away (left or right) and walks off.
Layout WallLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double rx = rng.uniform(6.0, 7.0), ry = rng.uniform(5.0, 6.0);
  const double X = rx / 2, Y = ry / 2;
  const double ty = rng.uniform(-0.5, 0.5), stop = rng.uniform(0.6, 0.8);
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const double sw = rng.uniform(0, 2) ? 0.3 : -0.3;  // switch beside the target point
  if (build_world) {
    const Polygon loop = {{-X, -Y}, {X, -Y}, {X, Y}, {-X, Y}};
    std::vector<WallFeatures> f(4);
    f[0].doors = {rng.uniform(1.5, rx - 1.5)};
    f[2].doors = {rng.uniform(1.5, rx - 1.5)};
    f[2].switches = {f[2].doors[0] + 0.75};
    f[3].doors = {Y + rng.uniform(-1.0, 1.0)};
    f[1].switches_at = {{Y + ty + sw, 1.3}};
    f[rng.uniform(0, 2) ? 0 : 2].pipe = true;
    f[1].posters_at = {Y + ty - 1.6 * sw};  // partly in view at the closest point
    AutoPosters(loop, 2, rng, &f);
    b->Loop(loop, f, true);
    b->FloorAndCeiling({-X - 0.5, -Y - 0.5}, {X + 0.5, Y + 0.5});
  }
  const double s = side, deg = kDeg;
  const double xs = X - stop;
  const Vec2 away(std::cos(s * 150 * deg), std::sin(s * 150 * deg));
  const Vec2 p_turned(xs - 0.45, ty + s * 0.1);
  const Vec2 p_walk1 = p_turned + 0.8 * away, p_walk2 = p_turned + 2.0 * away;
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, X - 4.6, ty + 0.2, 0.0, true},
      {1.5, X - 3.5, ty + 0.1, 2 * deg},
      {3.0, X - 1.9, ty, 0.0},
      {4.3, X - 1.0, ty, 0.0},
      {5.3, xs, ty, 0.0, true},
      {6.0, xs - 0.02, ty, s * 3 * deg},
      {7.2, xs - 0.2, ty + s * 0.03, s * 60 * deg},
      {8.4, p_turned.x(), p_turned.y(), s * 135 * deg},
      {9.4, p_walk1.x(), p_walk1.y(), s * 150 * deg},
      {11.0, p_walk2.x(), p_walk2.y(), s * 150 * deg, true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d m = motion->At(t);
    return WalkingPose(m.head<2>(), m.z(), t, 0.0);
  };
  return l;
}

// lowtex_office: a plain room with three shelf units on one wall seen head-on (approached,
// then passed sideways), a desk, and a whiteboard the walk turns to at the end. Mirrored
// left/right by the seed.
Layout OfficeLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double rx = rng.uniform(6.0, 7.0), ry = rng.uniform(5.0, 5.6);
  const double X = rx / 2, Y = ry / 2;
  const double m = rng.uniform(0, 2) ? 1.0 : -1.0;  // mirror x
  if (build_world) {
    const Polygon loop = {{-X, -Y}, {X, -Y}, {X, Y}, {-X, Y}};
    std::vector<WallFeatures> f(4);
    // East (or west when mirrored) wall: the whiteboard, centred 0.5 m south of the middle.
    const int board_wall = m > 0 ? 1 : 3;
    f[board_wall].whiteboard = m > 0 ? Y - 0.5 : Y + 0.5;
    f[0].doors = {X + m * rng.uniform(-2.2, -1.4)};
    f[0].switches = {f[0].doors[0] + 0.75};
    f[4 - board_wall].doors = {Y + rng.uniform(-0.8, 0.8)};
    f[0].pipe = true;
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    // Shelves on the north wall (y = Y), walked along at ~1.8 m.
    const Vec2 u = Vec2(-1.0, 0.0), n = Vec2(0.0, -1.0);  // north wall seen from the room
    for (int k = 0; k < 3; ++k) {
      const double width = rng.uniform(0.8, 1.0);
      const double cx = m * (-1.6 + 1.35 * k) + rng.uniform(-0.1, 0.1);
      b->Shelf(Vec2(cx + width / 2, Y), u, n, width, 0.35, rng.uniform(1.8, 2.0), rng.uniform(4, 6),
               rng.uniform(120.0, 160.0));
    }
    const double dx0 = m > 0 ? 0.2 : -1.6;
    b->Box({dx0, -Y + 0.02, 0.0}, {dx0 + 1.4, -Y + 0.72, 0.75}, 135);
    b->FloorAndCeiling({-X - 0.5, -Y - 0.5}, {X + 0.5, Y + 0.5});
  }
  const double deg = kDeg;
  auto yaw = [m](double a) { return m > 0 ? a : kPi - a; };
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, m * -2.0, -1.5, yaw(90 * deg), true},
      {1.6, m * -1.8, -0.4, yaw(90 * deg)},
      {3.0, m * -1.4, 0.5, yaw(88 * deg)},
      {5.0, m * -0.2, 0.7, yaw(92 * deg)},
      {7.0, m * 1.0, 0.6, yaw(85 * deg)},
      {8.4, m * 1.7, 0.3, yaw(40 * deg)},
      {9.8, m * 2.0, -0.5, yaw(0.0)},
      {11.2, m * 2.1, -1.2, yaw(-20 * deg), true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d v = motion->At(t);
    return WalkingPose(v.head<2>(), v.z(), t);
  };
  return l;
}

Layout MakeLayout(SceneKind kind, uint64_t world_seed, bool bare, bool build_world) {
  Builder b(world_seed, bare);
  switch (kind) {
    case SceneKind::kLowtexCorner:
      return CornerLayout(&b, build_world);
    case SceneKind::kLowtexStraight:
      return StraightLayout(&b, build_world);
    case SceneKind::kLowtexSpin:
      return SpinLayout(&b, build_world);
    case SceneKind::kLowtexDoorway:
      return DoorwayLayout(&b, build_world);
    case SceneKind::kLowtexWall:
      return WallLayout(&b, build_world);
    case SceneKind::kLowtexOffice:
      return OfficeLayout(&b, build_world);
    default:
      throw std::invalid_argument("BuildLowtexScene: " + SceneKindName(kind) +
                                  " is not a lowtex scene");
  }
}

}  // namespace

bool IsLowtexScene(SceneKind kind) {
  switch (kind) {
    case SceneKind::kLowtexCorner:
    case SceneKind::kLowtexStraight:
    case SceneKind::kLowtexSpin:
    case SceneKind::kLowtexDoorway:
    case SceneKind::kLowtexWall:
    case SceneKind::kLowtexOffice:
      return true;
    default:
      return false;
  }
}

int LowtexDefaultNumFrames(SceneKind kind, uint64_t world_seed, double rate_hz) {
  const Layout l = MakeLayout(kind, world_seed, true, false);
  return static_cast<int>(std::floor(l.duration * rate_hz)) + 1;
}

Scene BuildLowtexScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                       uint64_t world_seed, bool bare) {
  const Layout l = MakeLayout(kind, world_seed, bare, true);
  const int n =
      num_frames > 0 ? num_frames : static_cast<int>(std::floor(l.duration * rate_hz)) + 1;
  Scene scene;
  scene.world = l.world;
  scene.ground_truth.reserve(n);
  for (int i = 0; i < n; ++i) {
    StampedPose sp;
    const double t = i / rate_hz;
    sp.t = start_time_s + t;
    sp.T_w_c = l.pose(std::min(t, l.duration));
    scene.ground_truth.push_back(sp);
  }
  return scene;
}

}  // namespace pl_slam::sim
