// Internal to the low-texture scenes (lowtex_scenes.cpp): the world builder (plain graded
// walls with doors, skirting, rails, pipes, switches, posters; floors and ceilings; the
// structural edges they make) and the walking motion (paths, timing, keyed motions).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "pl_slam/sim/procedural_texture.h"
#include "pl_slam/sim/scenes.h"
#include "motion_timing.h"

namespace pl_slam::sim::lowtex {

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

inline Vec3 At(const Vec2& p, double z) { return Vec3(p.x(), p.y(), z); }

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
inline void AutoDoors(double length, cv::RNG& rng, WallFeatures* f) {
  for (double x = 1.2 + rng.uniform(0.0, 1.5); x < length - 1.2; x += rng.uniform(3.0, 4.5)) {
    f->doors.push_back(x);
    if (rng.uniform(0, 2) == 0) {
      const double s = x + (rng.uniform(0, 2) ? 0.75 : -0.75);
      if (s > 0.2 && s < length - 0.2) f->switches.push_back(s);
    }
  }
}

// Adds `count` posters to walls of length >= 2.5 m, chosen at random.
inline void AutoPosters(const Polygon& poly, int count, cv::RNG& rng,
                        std::vector<WallFeatures>* f) {
  std::vector<int> candidates;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    if ((poly[(i + 1) % poly.size()] - poly[i]).norm() >= 2.5) candidates.push_back(i);
  }
  for (int k = 0; k < count && !candidates.empty(); ++k) {
    (*f)[candidates[rng.uniform(0, static_cast<int>(candidates.size()))]].posters++;
  }
}

inline void BoundingBox(const Polygon& poly, Vec2* lo, Vec2* hi) {
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
inline Polygon CorridorLoop(const Polygon& centre, double half, std::vector<int>* right_edges,
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
class WalkTiming : public ArcLengthTable {
 public:
  WalkTiming(const Path2D& path, double speed, double turn_speed)
      : ArcLengthTable(path.length(), [&](double s) {
          const double turn = Smoothstep(path.DistanceToTurn(s) / 1.2);
          double v = turn_speed + (speed - turn_speed) * turn;
          v *= 0.35 + 0.65 * Smoothstep(s / 1.0);
          v *= 0.25 + 0.75 * Smoothstep((path.length() - s) / 0.8);
          return v;
        }) {}
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
inline SE3 WalkingPose(const Vec2& p, double yaw, double t, double pitch0 = 0.03) {
  const double z = kEye + 0.015 * std::sin(2 * kPi * 1.8 * t);
  const double pitch = pitch0 + 0.02 * std::sin(2 * kPi * t / 4.3 + 0.7);
  const double roll = 0.012 * std::sin(2 * kPi * 0.9 * t);
  return CameraPoseFromYawPitchRoll(At(p, z), yaw, pitch, roll);
}

}  // namespace pl_slam::sim::lowtex
