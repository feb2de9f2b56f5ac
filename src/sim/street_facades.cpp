// The street scenes' buildings: fronts drawn with windows, doors, shop fronts and signs (each
// outline a structural edge), rows of them along a street, and buildings closing its ends.
#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "street_building.h"

namespace pl_slam::sim::street {
namespace {

constexpr double kFrontTexel = 0.03;  // 3 cm: window frames (7 cm) stay 2+ texels wide
constexpr double kSideTexel = 0.05;   // walls between fronts, seen at grazing angles
constexpr double kBuildingDepth = 12.0;
constexpr double kMaxSagitta = 0.3;  // on bends, fronts are chords bulging at most this much

// Canvas coordinates: x metres along the front from its left end, y metres down from its top.
using EdgeFn = std::function<void(double x0, double y0, double x1, double y1)>;

void Rect(const EdgeFn& edge, double x0, double y0, double x1, double y1) {
  edge(x0, y0, x1, y0);
  edge(x0, y1, x1, y1);
  edge(x0, y0, x0, y1);
  edge(x1, y0, x1, y1);
}

// A glazed window [x0, x1] x [y0, y1] in a frame of width fw: glass with a reflection and
// maybe a curtain, a mullion when `mullion`, a sill under it.
void Window(TextureCanvas* c, cv::RNG& rng, const EdgeFn& edge, double x0, double y0, double x1,
            double y1, double frame_grey, double glass_grey, double sill_grey, bool mullion) {
  const double fw = 0.07;
  c->FillRect(x0 - fw, y0 - fw, x1 + fw, y1 + fw, frame_grey);
  const double glass = glass_grey + rng.uniform(-10.0, 10.0);
  c->FillRect(x0, y0, x1, y1, glass);
  if (rng.uniform(0.0, 1.0) < 0.6) {  // sky reflected in the lower part
    const double ya = y0 + (y1 - y0) * rng.uniform(0.2, 0.7);
    const double yb = y0 + (y1 - y0) * rng.uniform(0.2, 0.7);
    c->FillConvex({{x0, ya}, {x1, yb}, {x1, y1}, {x0, y1}}, glass + rng.uniform(15.0, 40.0));
  }
  if (rng.uniform(0.0, 1.0) < 0.35) {  // a curtain drawn on one side
    const double cw = (x1 - x0) * rng.uniform(0.2, 0.45);
    if (rng.uniform(0, 2)) {
      c->FillRect(x0, y0, x0 + cw, y1, rng.uniform(120.0, 210.0));
    } else {
      c->FillRect(x1 - cw, y0, x1, y1, rng.uniform(120.0, 210.0));
    }
  }
  if (mullion) c->FillRect((x0 + x1) / 2 - 0.03, y0, (x0 + x1) / 2 + 0.03, y1, frame_grey);
  c->FillRect(x0 - 0.1, y1 + fw, x1 + 0.1, y1 + fw + 0.07, sill_grey);
  Rect(edge, x0 - fw, y0 - fw, x1 + fw, y1 + fw);
  Rect(edge, x0, y0, x1, y1);
  edge(x0 - 0.1, y1 + fw + 0.07, x1 + 0.1, y1 + fw + 0.07);
}

// A shop front [x0, x1] on a ground floor `gf` high (canvas height h): shop window with goods
// behind it and a glass door, and a sign band with letters above.
void ShopFront(TextureCanvas* c, cv::RNG& rng, const EdgeFn& edge, double x0, double x1, double gf,
               double h, double wall_grey) {
  const double frame = rng.uniform(30.0, 70.0), fw = 0.1;
  const double top = h - (gf - 1.1), bottom = h - 0.35;
  c->FillRect(x0, top, x1, bottom, frame);
  const double glass = rng.uniform(35.0, 65.0);
  c->FillRect(x0 + fw, top + fw, x1 - fw, bottom - fw, glass);
  // Goods on display: boxes and shelves of many greys behind the glass.
  const int goods = static_cast<int>((x1 - x0) * 4);
  for (int i = 0; i < goods; ++i) {
    const double w = rng.uniform(0.15, 0.6), gh = rng.uniform(0.15, 0.7);
    const double gx = rng.uniform(x0 + fw, x1 - fw - w), gy = rng.uniform(top + 0.5, bottom - fw);
    c->FillRect(gx, std::max(top + fw, gy - gh), gx + w, gy, rng.uniform(60.0, 200.0));
  }
  // Glass door at one end.
  const bool left = rng.uniform(0, 2);
  const double d0 = left ? x0 + fw + 0.2 : x1 - fw - 1.2, d1 = d0 + 1.0;
  c->FillRect(d0 - 0.06, top + 0.4, d1 + 0.06, bottom - fw, frame);
  c->FillRect(d0, top + 0.46, d1, bottom - fw, glass - 10.0);
  c->FillRect(left ? d1 - 0.15 : d0 + 0.1, h - 1.1, left ? d1 - 0.1 : d0 + 0.15, h - 0.8, 200);
  Rect(edge, x0, top, x1, bottom);
  Rect(edge, x0 + fw, top + fw, x1 - fw, bottom - fw);
  Rect(edge, d0, top + 0.46, d1, bottom - fw);
  // Sign band with letters: contrasting background, strokes of the other tone.
  const double sy0 = h - gf + 0.3, sy1 = h - gf + 0.95;
  const double sign = wall_grey > 128 ? rng.uniform(20.0, 80.0) : rng.uniform(180.0, 245.0);
  const double ink = sign > 128 ? rng.uniform(10.0, 70.0) : rng.uniform(200.0, 250.0);
  const double sx0 = x0 + 0.1, sx1 = x1 - 0.1;
  c->FillRect(sx0, sy0, sx1, sy1, sign);
  Rect(edge, sx0, sy0, sx1, sy1);
  const double lh = (sy1 - sy0) * 0.6, ly = sy0 + (sy1 - sy0) * 0.2, st = lh * 0.16;
  for (double x = sx0 + rng.uniform(0.2, 0.6); x < sx1 - 0.4;) {
    const double lw = rng.uniform(0.16, 0.3);
    if (rng.uniform(0.0, 1.0) < 0.15) {  // a space between words
      x += lw;
      continue;
    }
    const int strokes = rng.uniform(1, 4);
    for (int k = 0; k < strokes; ++k) {
      const double at = rng.uniform(0, 3) / 2.0;  // left / top, middle, right / bottom
      switch (rng.uniform(0, 4)) {
        case 0:  // vertical
          c->FillRect(x + (lw - st) * at, ly, x + (lw - st) * at + st, ly + lh, ink);
          break;
        case 1:  // horizontal
          c->FillRect(x, ly + (lh - st) * at, x + lw, ly + (lh - st) * at + st, ink);
          break;
        case 2:  // diagonal
          c->Line({x, ly + lh}, {x + lw, ly}, st, ink);
          break;
        default:  // bowl
          c->FillEllipse({x + lw / 2, ly + lh / 2}, lw / 2, lh / 2, 0, ink);
          c->FillEllipse({x + lw / 2, ly + lh / 2}, lw / 2 - st, lh / 2 - st, 0, sign);
          break;
      }
    }
    x += lw + rng.uniform(0.05, 0.1);
  }
}

// A building front w x h metres: plaster with a parapet, floor bands, rows of windows, and a
// ground floor with shop fronts or a front door and windows. Outlines go to `edge`.
std::shared_ptr<const Texture> DrawFront(double w, double h, const BuildingStyle& style,
                                         cv::RNG& rng, const EdgeFn& edge) {
  const double grey = rng.uniform(105.0, 200.0);
  TextureCanvas c(w, h, kFrontTexel, grey);
  c.AddNoise(6.0, 2.0, 3, 0.5, rng);
  const double gf = rng.uniform(3.8, 4.6), fh = rng.uniform(2.9, 3.4);
  const int floors = std::max(0, static_cast<int>((h - gf - 0.8) / fh));
  const double light = std::min(245.0, grey + 45.0), dark = std::max(20.0, grey - 60.0);
  const double frame = rng.uniform(0, 2) ? light : dark;
  const double glass = rng.uniform(30.0, 70.0);
  const double sill = std::min(250.0, grey + 30.0);
  const bool mullions = rng.uniform(0.0, 1.0) < 0.6;
  const bool bands = rng.uniform(0.0, 1.0) < 0.5;

  // Parapet, and the band over the ground floor.
  c.FillRect(0, 0, w, 0.3, grey - 25.0);
  edge(0, 0.3, w, 0.3);
  const double yb = h - gf;
  c.FillRect(0, yb - 0.12, w, yb + 0.12, std::min(250.0, grey + 22.0));
  edge(0, yb - 0.12, w, yb - 0.12);
  edge(0, yb + 0.12, w, yb + 0.12);
  if (bands) {
    for (int k = 1; k < floors; ++k) {
      const double y = yb - k * fh;
      c.FillRect(0, y - 0.05, w, y + 0.05, grey - 15.0);
      edge(0, y - 0.05, w, y - 0.05);
      edge(0, y + 0.05, w, y + 0.05);
    }
  }

  // Upper floors: a regular grid of windows.
  const double spacing = rng.uniform(style.window_spacing_lo, style.window_spacing_hi);
  const double ww =
      std::min(rng.uniform(style.window_width_lo, style.window_width_hi), spacing - 0.7);
  const double wh = rng.uniform(1.35, 1.8);
  const int cols = std::max(1, static_cast<int>((w - 1.0) / spacing));
  const double first = (w - (cols - 1) * spacing) / 2;
  for (int k = 1; k <= floors; ++k) {
    const double sill_z = gf + (k - 1) * fh + 0.85, top_z = sill_z + wh;
    if (top_z > h - 0.6) continue;
    for (int i = 0; i < cols; ++i) {
      if (rng.uniform(0.0, 1.0) < 0.05) continue;  // a blind window now and then
      const double xc = first + i * spacing;
      Window(&c, rng, edge, xc - ww / 2, h - top_z, xc + ww / 2, h - sill_z, frame, glass, sill,
             mullions);
    }
  }

  // Ground floor over a plinth; plinth edges only where nothing covers them.
  c.FillRect(0, h - 0.35, w, h, grey * 0.7);
  std::vector<std::pair<double, double>> covered;
  if (rng.uniform(0.0, 1.0) < style.shop_fraction && w > 4.0) {
    const int shops = std::max(1, static_cast<int>(std::round((w - 1.2) / rng.uniform(4.5, 8.0))));
    const double unit = (w - 1.2) / shops;
    for (int i = 0; i < shops; ++i) {
      const double x0 = 0.6 + i * unit + 0.3, x1 = 0.6 + (i + 1) * unit - 0.3;
      ShopFront(&c, rng, edge, x0, x1, gf, h, grey);
      covered.emplace_back(x0, x1);
    }
  } else {
    const int door = rng.uniform(0, cols);
    for (int i = 0; i < cols; ++i) {
      const double xc = first + i * spacing;
      if (i == door) {  // front door: frame, leaf with two panels
        const double d0 = xc - 0.6, d1 = xc + 0.6, top = h - 2.5;
        c.FillRect(d0 - 0.1, top - 0.1, d1 + 0.1, h, light);
        c.FillRect(d0, top, d1, h, rng.uniform(35.0, 85.0));
        c.FillRect(d0 + 0.15, top + 0.2, d1 - 0.15, top + 1.1, rng.uniform(90.0, 130.0));
        c.FillRect(d0 + 0.15, top + 1.3, d1 - 0.15, h - 0.25, rng.uniform(90.0, 130.0));
        Rect(edge, d0 - 0.1, top - 0.1, d1 + 0.1, h);
        Rect(edge, d0, top, d1, h);
        covered.emplace_back(d0 - 0.1, d1 + 0.1);
      } else {
        Window(&c, rng, edge, xc - ww / 2, h - 1.2 - wh, xc + ww / 2, h - 1.2, frame, glass, sill,
               false);
      }
    }
  }
  std::sort(covered.begin(), covered.end());
  double x = 0.0;
  for (const auto& [lo, hi] : covered) {
    if (lo > x) edge(x, h - 0.35, lo, h - 0.35);
    x = std::max(x, hi);
  }
  if (x < w) edge(x, h - 0.35, w, h - 0.35);
  if (rng.uniform(0.0, 1.0) < 0.5) {  // a downpipe at one end
    const double px = rng.uniform(0, 2) ? 0.25 : w - 0.35;
    c.FillRect(px, 0.3, px + 0.1, h, grey - 40.0);
    edge(px, 0.3, px, h);
    edge(px + 0.1, 0.3, px + 0.1, h);
  }
  return c.Finish(0.04, 3.0, 1.5, rng);
}

// A plain wall texture (the side of a building), its grey a shade of the front's.
std::shared_ptr<const Texture> SideWall(double w, double h, cv::RNG& rng) {
  TextureCanvas c(w, h, kSideTexel, rng.uniform(95.0, 175.0));
  c.AddNoise(4.0, 3.0, 3, 0.5, rng);
  c.FillRect(0, 0, w, 0.3, c.albedo().at<uint8_t>(0, 0) - 20.0);
  return c.Finish(0.05, 3.0, 1.5, rng);
}

}  // namespace

void StreetBuilder::Front(const Vec2& a, const Vec2& b, double height, const BuildingStyle& style) {
  const double w = (b - a).norm();
  const Vec2 u = (b - a) / w;
  cv::RNG rng(Tag());
  auto P = [&](double x, double y) { return At(a + x * u, height - y); };
  const EdgeFn edge = [&](double x0, double y0, double x1, double y1) {
    Edge(P(x0, y0), P(x1, y1));
  };
  Quad(At(a, height), At(b - a, 0.0), Vec3(0, 0, -height), DrawFront(w, height, style, rng, edge));
  Edge(P(0, 0), P(w, 0));  // roof line against the sky
  Edge(P(0, height), P(w, height));
  Edge(P(0, 0), P(0, height));
  Edge(P(w, 0), P(w, height));
}

void StreetBuilder::BuildingRow(const StreetSpec& st, int side, double s0, double s1,
                                const BuildingStyle& style) {
  const StreetPath& c = st.centre;
  // Cut the row into buildings; on bends a front is short enough to stay close to the
  // building line (a chord of radius R and width w bulges w^2 / 8R).
  std::vector<double> cuts = {s0};
  for (double s = s0; s < s1;) {
    double w = rng_.uniform(style.width_lo, style.width_hi);
    double k = 0.0;
    for (double t = s; t <= s + w; t += 2.0) k = std::max(k, std::abs(c.Curvature(t)));
    if (k > 0.0) {
      const double radius = std::max(10.0, 1.0 / k - st.building_line() - style.setback_hi);
      w = std::min(w, std::sqrt(8.0 * kMaxSagitta * radius));
    }
    if (s1 - (s + w) < 0.6 * style.width_lo) w = s1 - s;
    s += w;
    cuts.push_back(s);
  }
  const std::size_t n = cuts.size() - 1;
  std::vector<double> setback(n), height(n);
  for (std::size_t i = 0; i < n; ++i) {
    setback[i] = st.building_line() + rng_.uniform(0.0, style.setback_hi);
    height[i] = rng_.uniform(style.height_lo, style.height_hi);
  }
  auto corner = [&](double s, double d) -> Vec2 { return c.Position(s) + side * d * c.Left(s); };
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 p0 = corner(cuts[i], setback[i]), p1 = corner(cuts[i + 1], setback[i]);
    // Seen from the street, the front's left end is the one at lower s on the left side.
    if (side > 0) {
      Front(p0, p1, height[i], style);
    } else {
      Front(p1, p0, height[i], style);
    }
  }
  // Walls across the building line: where fronts step back or heights change, and at both
  // ends of the row. Each runs outward from the street along the normal at its cut.
  auto wall = [&](double s, double d_from, double d_to, double h) {
    if (d_to - d_from < 0.01) return;
    const Vec2 a = corner(s, d_from), b = corner(s, d_to);
    Quad(At(a, h), At(b - a, 0.0), Vec3(0, 0, -h), SideWall(d_to - d_from, h, rng_));
    Edge(At(a, h), At(b, h));
  };
  for (std::size_t j = 0; j <= n; ++j) {
    if (j == 0 || j == n) {
      // The ends of a row face cross streets (or the open space behind the car): fronts
      // with windows, their left end as seen from outside the row first.
      const std::size_t i = j == 0 ? 0 : n - 1;
      const Vec2 near = corner(cuts[j], setback[i]);
      const Vec2 far = corner(cuts[j], setback[i] + kBuildingDepth);
      if ((side > 0) == (j == n)) {
        Front(near, far, height[i], style);
      } else {
        Front(far, near, height[i], style);
      }
      continue;
    }
    const std::size_t a = j - 1, b = j;
    const std::size_t tall = height[a] >= height[b] ? a : b, low = tall == a ? b : a;
    if (std::abs(height[a] - height[b]) > 0.01) {
      wall(cuts[j], setback[tall], setback[tall] + kBuildingDepth, height[tall]);
    }
    if (setback[low] < setback[tall]) {
      wall(cuts[j], setback[low], setback[tall], height[low]);
    } else if (setback[tall] < setback[low] && std::abs(height[a] - height[b]) <= 0.01) {
      wall(cuts[j], setback[tall], setback[low], height[tall]);
    }
  }
}

void StreetBuilder::EndBuilding(const StreetSpec& st, double s, double overhang,
                                const BuildingStyle& style) {
  const double half = st.building_line() + style.setback_hi + overhang;
  const Vec2 p = st.centre.Position(s), left = st.centre.Left(s);
  const double h = rng_.uniform(style.height_lo, style.height_hi);
  // Facing back along the street at its far end (s = s_end), forward at its start.
  if (s >= st.s_end) {
    Front(p + half * left, p - half * left, h, style);
  } else {
    Front(p - half * left, p + half * left, h, style);
  }
}

}  // namespace pl_slam::sim::street
