// The street scenes' centre lines and their world builder, less the building fronts
// (street_facades.cpp): ground tiles, parked cars, lamp posts with signs, trees.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <utility>

#include "street_building.h"

namespace pl_slam::sim::street {
namespace {

constexpr double kGroundTile = 20.0;   // metres per ground quad (one texture each)
constexpr double kGroundTexel = 0.03;  // 3.4 px per texel at the nearest visible road (6 m)
constexpr int kGroundGridStep = 8;     // texels between exactly evaluated grid nodes
constexpr double kKerbWidth = 0.18;    // kerb stones between road and pavement
constexpr double kLineHalf = 0.06;     // half width of lane lines
constexpr double kSlab = 0.6;          // pavement slab size

Vec2 Direction(double h) { return {std::cos(h), std::sin(h)}; }

double WrapPi(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Smooth value noise in [-1, 1] with unit cells, continuous everywhere (so ground tiles
// drawn from it meet without seams).
double Lattice(int64_t i, int64_t j, uint64_t seed) {
  const uint64_t h = MixSeed(MixSeed(seed, static_cast<uint64_t>(i)), static_cast<uint64_t>(j));
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

double ValueNoise(double x, double y, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t i = static_cast<int64_t>(fx), j = static_cast<int64_t>(fy);
  const double u = Smoothstep(x - fx), v = Smoothstep(y - fy);
  const double a = Lattice(i, j, seed), b = Lattice(i + 1, j, seed);
  const double c = Lattice(i, j + 1, seed), d = Lattice(i + 1, j + 1, seed);
  return (a + u * (b - a)) * (1.0 - v) + (c + u * (d - c)) * v;
}

// Anti-aliased coverage of a shape at signed distance d (negative inside) over one texel.
double Coverage(double d) { return std::clamp(0.5 - d / kGroundTexel, 0.0, 1.0); }

// Signed distance to the dashes [0, dash] repeated every `period` along s.
double DashDistance(double s, double dash, double period) {
  const double u = s - period * std::floor(s / period);
  if (u <= dash) return std::max(-u, u - dash);
  return std::min(u - dash, period - u);
}

// Lane markings of one street at (s, l): coverage 0..1.
double Markings(const StreetSpec& st, double s, double l) {
  for (const auto& [lo, hi] : st.plain)
    if (s > lo && s < hi) return 0.0;
  const double a = std::abs(l);
  const double lanes_edge = st.lanes * st.lane_width;
  double d = std::numeric_limits<double>::infinity();
  if (st.lanes == 1) {
    d = std::max(a - kLineHalf, DashDistance(s, 3.0, 9.0));  // dashed centre line
  } else {
    d = std::abs(a - 0.15) - kLineHalf;  // double solid centre line
    for (int k = 1; k < st.lanes; ++k) {
      d = std::min(
          d, std::max(std::abs(a - k * st.lane_width) - kLineHalf, DashDistance(s, 3.0, 9.0)));
    }
  }
  if (st.parking > 0.0) d = std::min(d, std::abs(a - lanes_edge) - kLineHalf);
  for (std::size_t i = 0; i < st.crossings.size(); ++i) {
    const double c = st.crossings[i];
    // Zebra: 0.5 m bars along the road, 0.5 m apart, 4 m long, kerb to kerb.
    const double bar = std::abs(l + 0.25 - std::round(l + 0.25)) - 0.25;
    d = std::min(d, std::max({std::abs(s - c) - 2.0, bar, a - (st.road_half() - 0.3)}));
    if (i == 0) {  // stop lines on both sides, 1.8 m from the zebra
      d = std::min(d, std::max({std::abs(s - (c - 3.9)) - 0.2, -l - lanes_edge, l}));
      d = std::min(d, std::max({std::abs(s - (c + 3.9)) - 0.2, l - lanes_edge, -l}));
    }
  }
  return Coverage(d);
}

// One exactly evaluated point of the ground: per street (s, l) and two noise octaves.
struct GroundNode {
  std::vector<double> s, l;
  double n_coarse = 0.0, n_fine = 0.0, n_patch = 0.0;
};

// Grey level of the ground at a point with the given per-street coordinates and noise.
float GroundGrey(const std::vector<const StreetSpec*>& streets, const GroundNode& n,
                 uint64_t seed) {
  int roads = 0, road = -1, near = -1;
  double best_margin = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < streets.size(); ++k) {
    const StreetSpec& st = *streets[k];
    if (n.s[k] < st.s_begin - 0.5 || n.s[k] > st.s_end + 0.5) continue;
    const double margin = std::abs(n.l[k]) - st.road_half();
    if (margin < 0.0) {
      ++roads;
      road = static_cast<int>(k);
    }
    if (margin < best_margin) {
      best_margin = margin;
      near = static_cast<int>(k);
    }
  }
  if (roads > 0) {
    double g = 84.0 + 7.0 * n.n_coarse + 4.0 * n.n_fine;
    g -= 11.0 * Smoothstep((n.n_patch - 0.45) / 0.04);  // repaired patches
    if (roads == 1) g += Markings(*streets[road], n.s[road], n.l[road]) * (212.0 - g);
    return static_cast<float>(g);
  }
  if (near >= 0 && best_margin < kKerbWidth) {  // kerb stones, a joint every metre
    const double joint = std::abs(n.s[near] - std::round(n.s[near])) - 0.008;
    const double g = 168.0 + 4.0 * n.n_fine;
    return static_cast<float>(g - 60.0 * Coverage(joint * 1.0));
  }
  // Pavement slabs in the nearest street's frame (or the world's when none is near).
  double u = 0.0, v = 0.0;
  if (near >= 0) {
    u = n.s[near];
    v = best_margin - kKerbWidth;
  }
  const double iu = std::floor(u / kSlab), iv = std::floor(v / kSlab);
  const double ju = std::abs(u - kSlab * std::round(u / kSlab)) - 0.008;
  const double jv = std::abs(v - kSlab * std::round(v / kSlab)) - 0.008;
  const double slab = Lattice(static_cast<int64_t>(iu), static_cast<int64_t>(iv), seed ^ 0x51ab);
  const double g = 146.0 + 9.0 * slab + 5.0 * n.n_coarse + 3.0 * n.n_fine;
  return static_cast<float>(g - 45.0 * Coverage(std::min(ju, jv)));
}

}  // namespace

// ---------------------------------------------------------------------------- StreetPath

StreetPath::StreetPath(const Polygon& w, const std::vector<double>& radii) {
  Vec2 cur = w[0];
  for (std::size_t i = 1; i < w.size(); ++i) {
    const Vec2 d_in = (w[i] - w[i - 1]).normalized();
    const double h_in = std::atan2(d_in.y(), d_in.x());
    if (i + 1 == w.size()) {
      Add(cur, h_in, (w[i] - cur).norm(), 0.0);
      break;
    }
    const Vec2 d_out = (w[i + 1] - w[i]).normalized();
    const double phi = std::atan2(d_in.x() * d_out.y() - d_in.y() * d_out.x(), d_in.dot(d_out));
    const double r = radii.at(i - 1);
    const double t = r * std::tan(std::abs(phi) / 2);
    const Vec2 arc_start = w[i] - t * d_in;
    Add(cur, h_in, (arc_start - cur).norm(), 0.0);
    if (std::abs(phi) > 1e-12) Add(arc_start, h_in, r * std::abs(phi), (phi > 0 ? 1.0 : -1.0) / r);
    cur = w[i] + t * d_out;
  }
}

void StreetPath::Add(const Vec2& p0, double h0, double len, double k) {
  const double s0 = pieces_.empty() ? 0.0 : pieces_.back().s0 + pieces_.back().len;
  pieces_.push_back({p0, h0, s0, std::max(0.0, len), k});
}

const StreetPath::Piece& StreetPath::Find(double s) const {
  for (const Piece& p : pieces_)
    if (s < p.s0 + p.len) return p;
  return pieces_.back();
}

Vec2 StreetPath::PieceAt(const Piece& p, double r) {
  if (p.k == 0.0) return p.p0 + r * Direction(p.h0);
  const double h = p.h0 + p.k * r;
  return p.p0 + Vec2(std::sin(h) - std::sin(p.h0), std::cos(p.h0) - std::cos(h)) / p.k;
}

double StreetPath::length() const { return pieces_.back().s0 + pieces_.back().len; }

Vec2 StreetPath::Position(double s) const {
  if (s < 0.0) return pieces_.front().p0 + s * Direction(pieces_.front().h0);
  const double end = length();
  if (s > end)
    return PieceAt(pieces_.back(), pieces_.back().len) + (s - end) * Direction(Heading(end));
  const Piece& p = Find(s);
  return PieceAt(p, s - p.s0);
}

double StreetPath::Heading(double s) const {
  const Piece& p = Find(std::clamp(s, 0.0, length()));
  return p.h0 + p.k * std::clamp(s - p.s0, 0.0, p.len);
}

double StreetPath::Curvature(double s) const {
  if (s < 0.0 || s > length()) return 0.0;
  return Find(s).k;
}

Vec2 StreetPath::Left(double s) const {
  const double h = Heading(s);
  return {-std::sin(h), std::cos(h)};
}

StreetPath StreetPath::Offset(double lateral) const {
  StreetPath out;
  for (const Piece& p : pieces_) {
    const double scale = 1.0 - p.k * lateral;
    out.Add(p.p0 + lateral * Vec2(-std::sin(p.h0), std::cos(p.h0)), p.h0, p.len * scale,
            p.k / scale);
  }
  return out;
}

void StreetPath::Project(const Vec2& p, double* s, double* lateral) const {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    const Piece& piece = pieces_[i];
    double r;
    if (piece.k == 0.0) {
      r = (p - piece.p0).dot(Direction(piece.h0));
      if (i > 0) r = std::max(r, 0.0);
      if (i + 1 < pieces_.size()) r = std::min(r, piece.len);
    } else {
      const Vec2 c = piece.p0 + Vec2(-std::sin(piece.h0), std::cos(piece.h0)) / piece.k;
      const Vec2 u = (p - c).normalized();
      const double h = piece.k > 0 ? std::atan2(u.x(), -u.y()) : std::atan2(-u.x(), u.y());
      r = std::clamp(WrapPi(h - piece.h0) / piece.k, 0.0, piece.len);
    }
    const Vec2 q = PieceAt(piece, r);
    const double d = (p - q).norm();
    if (d < best) {
      best = d;
      *s = piece.s0 + r;
      const double h = piece.h0 + piece.k * r;
      *lateral = (p - q).dot(Vec2(-std::sin(h), std::cos(h)));
    }
  }
}

double StreetPath::DistanceToCurve(double s, double k_min) const {
  double best = 1e9;
  for (const Piece& p : pieces_) {
    if (std::abs(p.k) < k_min) continue;
    best = std::min(best, std::max({0.0, p.s0 - s, s - (p.s0 + p.len)}));
  }
  return best;
}

// ------------------------------------------------------------------------- StreetBuilder

StreetBuilder::StreetBuilder(uint64_t seed)
    : world_(std::make_shared<World>()), seed_(seed), rng_(MixSeed(seed, 0x57ee7)) {
  // The sky: a plain bright grey where rays leave the world (no depth, no texture).
  world_->set_background(206.0f);
}

void StreetBuilder::Quad(const Vec3& corner, const Vec3& edge_u, const Vec3& edge_v,
                         std::shared_ptr<const Texture> texture) {
  world_->AddQuad(MakeQuad(corner, edge_u, edge_v, std::move(texture)));
}

void StreetBuilder::Ground(const std::vector<const StreetSpec*>& streets) {
  // Tiles whose centre lies within reach of a street's paved band.
  Vec2 lo(1e18, 1e18), hi(-1e18, -1e18);
  for (const StreetSpec* st : streets) {
    for (double s = st->s_begin; s <= st->s_end + 1.0; s += 5.0) {
      const Vec2 p = st->centre.Position(std::min(s, st->s_end));
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const double reach = 30.0;
  lo -= Vec2(reach, reach);
  hi += Vec2(reach, reach);
  const double half_diag = kGroundTile * std::sqrt(0.5);
  std::vector<Vec2, Eigen::aligned_allocator<Vec2>> tiles;
  for (double x = std::floor(lo.x() / kGroundTile) * kGroundTile; x < hi.x(); x += kGroundTile) {
    for (double y = std::floor(lo.y() / kGroundTile) * kGroundTile; y < hi.y(); y += kGroundTile) {
      const Vec2 c(x + kGroundTile / 2, y + kGroundTile / 2);
      for (const StreetSpec* st : streets) {
        double s, l;
        st->centre.Project(c, &s, &l);
        if (std::abs(l) < st->building_line() + 3.0 + half_diag && s > st->s_begin - half_diag &&
            s < st->s_end + half_diag) {
          tiles.emplace_back(x, y);
          break;
        }
      }
    }
  }
  const uint64_t noise_seed = Tag();
  std::vector<uint64_t> grain_seeds;
  for (std::size_t i = 0; i < tiles.size(); ++i) grain_seeds.push_back(Tag());
  std::vector<std::shared_ptr<const Texture>> textures(tiles.size());
  const int n = static_cast<int>(std::lround(kGroundTile / kGroundTexel));
  const int g = n / kGroundGridStep + 2;
  // Each tile is independent and seeded by its index: the thread count does not matter.
  cv::parallel_for_(cv::Range(0, static_cast<int>(tiles.size())), [&](const cv::Range& range) {
    std::vector<GroundNode> nodes(g * g);
    for (int t = range.start; t < range.end; ++t) {
      const Vec2 origin = tiles[t];
      auto node_pos = [&](int a) { return (a * kGroundGridStep + 0.5) * kGroundTexel; };
      for (int b = 0; b < g; ++b) {
        for (int a = 0; a < g; ++a) {
          GroundNode& nd = nodes[b * g + a];
          const Vec2 p = origin + Vec2(node_pos(a), node_pos(b));
          nd.s.resize(streets.size());
          nd.l.resize(streets.size());
          for (std::size_t k = 0; k < streets.size(); ++k)
            streets[k]->centre.Project(p, &nd.s[k], &nd.l[k]);
          nd.n_coarse = ValueNoise(p.x() / 3.0, p.y() / 3.0, noise_seed);
          nd.n_fine = ValueNoise(p.x() / 0.7, p.y() / 0.7, noise_seed + 1);
          nd.n_patch = ValueNoise(p.x() / 2.2, p.y() / 2.2, noise_seed + 2);
        }
      }
      cv::Mat f(n, n, CV_32F);
      GroundNode q;
      q.s.resize(streets.size());
      q.l.resize(streets.size());
      for (int j = 0; j < n; ++j) {
        const int b = j / kGroundGridStep;
        const double fb = static_cast<double>(j % kGroundGridStep) / kGroundGridStep;
        float* row = f.ptr<float>(j);
        for (int i = 0; i < n; ++i) {
          const int a = i / kGroundGridStep;
          const double fa = static_cast<double>(i % kGroundGridStep) / kGroundGridStep;
          const GroundNode& n00 = nodes[b * g + a];
          const GroundNode& n10 = nodes[b * g + a + 1];
          const GroundNode& n01 = nodes[(b + 1) * g + a];
          const GroundNode& n11 = nodes[(b + 1) * g + a + 1];
          auto mix = [&](double v00, double v10, double v01, double v11) {
            return (v00 + fa * (v10 - v00)) * (1.0 - fb) + (v01 + fa * (v11 - v01)) * fb;
          };
          for (std::size_t k = 0; k < streets.size(); ++k) {
            q.s[k] = mix(n00.s[k], n10.s[k], n01.s[k], n11.s[k]);
            q.l[k] = mix(n00.l[k], n10.l[k], n01.l[k], n11.l[k]);
          }
          q.n_coarse = mix(n00.n_coarse, n10.n_coarse, n01.n_coarse, n11.n_coarse);
          q.n_fine = mix(n00.n_fine, n10.n_fine, n01.n_fine, n11.n_fine);
          q.n_patch = mix(n00.n_patch, n10.n_patch, n01.n_patch, n11.n_patch);
          row[i] = GroundGrey(streets, q, noise_seed);
        }
      }
      cv::RNG grain_rng(grain_seeds[t]);
      cv::Mat grain(f.size(), CV_32F);
      grain_rng.fill(grain, cv::RNG::NORMAL, 0.0, 3.0);
      f += grain;
      textures[t] = std::make_shared<const Texture>(f);
    }
  });
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    Quad(At(tiles[t], 0.0), Vec3(kGroundTile, 0, 0), Vec3(0, kGroundTile, 0), textures[t]);
  }
}

void StreetBuilder::Box(const Vec2& c, double heading, double half_len, double half_wid, double z0,
                        double z1, int faces, const Face& texture) {
  const Vec2 f = Direction(heading), l(-f.y(), f.x());
  const Vec2 fl = c + half_len * f + half_wid * l, fr = c + half_len * f - half_wid * l;
  const Vec2 bl = c - half_len * f + half_wid * l, br = c - half_len * f - half_wid * l;
  const double h = z1 - z0;
  const Vec3 down(0, 0, -h);
  if (faces & 1) Quad(At(fl, z1), At(fr - fl, 0), down, texture(0, 2 * half_wid, h));
  if (faces & 2) Quad(At(br, z1), At(bl - br, 0), down, texture(1, 2 * half_wid, h));
  if (faces & 4) Quad(At(bl, z1), At(fl - bl, 0), down, texture(2, 2 * half_len, h));
  if (faces & 8) Quad(At(fr, z1), At(br - fr, 0), down, texture(3, 2 * half_len, h));
  if (faces & 16)
    Quad(At(bl, z1), At(fl - bl, 0), At(br - bl, 0), texture(4, 2 * half_len, 2 * half_wid));
  if (faces & 32)
    Quad(At(bl, z0), At(fl - bl, 0), At(br - bl, 0), texture(5, 2 * half_len, 2 * half_wid));
  const Vec2 ring[4] = {fl, fr, br, bl};
  for (int i = 0; i < 4; ++i) {
    Edge(At(ring[i], z0), At(ring[(i + 1) % 4], z0));
    Edge(At(ring[i], z1), At(ring[(i + 1) % 4], z1));
    Edge(At(ring[i], z0), At(ring[i], z1));
  }
}

void StreetBuilder::Car(const Vec2& c, double heading) {
  cv::RNG& r = rng_;
  const double len = r.uniform(3.9, 4.7), wid = r.uniform(1.72, 1.86);
  const double z0 = 0.18, z1 = r.uniform(0.92, 1.05);
  const double cabin_len = len * r.uniform(0.45, 0.56), cabin_h = r.uniform(0.4, 0.52);
  const double grey = r.uniform(30.0, 225.0);
  const double glass = r.uniform(30.0, 60.0);
  const double dark = grey * 0.45;
  const uint64_t seed = Tag();
  auto finish = [&](TextureCanvas& cv, int face) {
    cv::RNG g(MixSeed(seed, face));
    return cv.Finish(0.03, 0.8, 1.5, g);
  };
  Box(c, heading, len / 2, wid / 2, z0, z1, 31, [&](int face, double w, double h) {
    TextureCanvas cv(w, h, 0.01, face == 4 ? std::min(grey + 14.0, 250.0) : grey);
    if (face == 2 || face == 3) {  // sides: sill, wheel arches and wheels, door lines, handles
      cv.FillRect(0, h - 0.12, w, h, dark);
      const double wheel_y = h - (0.33 - z0);  // wheel centres 0.33 m above the road
      for (double x : {0.8, w - 0.8}) {
        cv.FillEllipse({x, wheel_y}, 0.42, 0.42, 0, dark * 0.7);
        cv.FillEllipse({x, wheel_y}, 0.33, 0.33, 0, 24);
        cv.FillEllipse({x, wheel_y}, 0.19, 0.19, 0, 150);
      }
      for (double x : {0.42 * w, 0.7 * w}) cv.Line({x, 0.05}, {x, h - 0.14}, 0.008, dark);
      for (double x : {0.48 * w, 0.76 * w}) cv.FillRect(x, 0.14, x + 0.14, 0.18, dark);
    } else if (face == 0 || face == 1) {  // front: grille, headlights; back: tail lights
      const bool front = face == 0;
      cv.FillRect(0, h - 0.16, w, h, dark);                              // bumper
      cv.FillRect(w / 2 - 0.26, h - 0.34, w / 2 + 0.26, h - 0.21, 232);  // number plate
      cv.FrameRect(w / 2 - 0.26, h - 0.34, w / 2 + 0.26, h - 0.21, 0.012, 30);
      if (front) cv.FillRect(w / 2 - 0.35, 0.12, w / 2 + 0.35, 0.3, 28);  // grille
      for (double x : {0.08, w - 0.46}) cv.FillRect(x, 0.06, x + 0.38, 0.2, front ? 236 : 66);
    }
    return finish(cv, face);
  });
  const Vec2 f(std::cos(heading), std::sin(heading));
  Box(c - 0.06 * len * f, heading, cabin_len / 2, wid / 2 - 0.08, z1, z1 + cabin_h, 31,
      [&](int face, double w, double h) {
        TextureCanvas cv(w, h, 0.01, face == 4 ? std::min(grey + 20.0, 250.0) : grey);
        if (face == 2 || face == 3) {  // side windows with A, B and C pillars
          cv.FillRect(0.16, 0.05, w - 0.12, h - 0.04, glass);
          cv.FillRect(w * 0.5 - 0.04, 0.0, w * 0.5 + 0.04, h, grey);
        } else if (face == 0 || face == 1) {  // windscreen, rear window
          cv.FillRect(0.07, 0.04, w - 0.07, h - 0.05, glass + 8);
        }
        return finish(cv, 10 + face);
      });
}

void StreetBuilder::ParkedCars(const StreetSpec& st, int side, double s0, double s1,
                               double occupancy) {
  for (double s = s0 + 2.8; s + 2.8 < s1; s += 5.6) {
    const bool taken = rng_.uniform(0.0, 1.0) < occupancy;
    const double jitter = rng_.uniform(-0.4, 0.4), lateral = rng_.uniform(-0.12, 0.12);
    const double yaw = rng_.uniform(-1.5, 1.5) * kDeg;
    if (!taken) continue;
    bool clear = true;
    for (double c : st.crossings) clear = clear && std::abs(s - c) > 9.0;
    for (const auto& [lo, hi] : st.plain) clear = clear && (s < lo - 12.0 || s > hi + 12.0);
    if (!clear) continue;
    const double sc = s + jitter;
    const Vec2 p = st.centre.Position(sc) +
                   side * (st.road_half() - st.parking / 2 + lateral) * st.centre.Left(sc);
    Car(p, st.centre.Heading(sc) + yaw);
  }
}

void StreetBuilder::Posts(const StreetSpec& st, int side, double s0, double s1, double spacing) {
  for (double s = s0 + rng_.uniform(0.0, spacing); s < s1;
       s += spacing * rng_.uniform(0.85, 1.15)) {
    const Vec2 left = st.centre.Left(s);
    const Vec2 base = st.centre.Position(s) + side * (st.road_half() + 0.6) * left;
    const double height = rng_.uniform(6.5, 8.0);
    const double grey = rng_.uniform(80.0, 130.0);
    const uint64_t seed = Tag();
    auto plain = [&](double g) {
      return [g, seed](int face, double w, double h) {
        TextureCanvas c(w, h, 0.02, g + 10.0 * ((face % 3) - 1));
        cv::RNG r(MixSeed(seed, face));
        return c.Finish(0.04, 0.5, 1.5, r);
      };
    };
    const double heading = st.centre.Heading(s);
    Box(base, heading, 0.07, 0.07, 0.0, height, 31, plain(grey));
    // Arm over the road and the lamp under its end (its bottom lit).
    const Vec2 toward = -side * left;
    const double arm_heading = std::atan2(toward.y(), toward.x());
    Box(base + 0.95 * toward, arm_heading, 0.9, 0.05, height - 0.12, height - 0.02, 63,
        plain(grey));
    Box(base + 1.7 * toward, arm_heading, 0.3, 0.14, height - 0.3, height - 0.12, 63,
        [&](int face, double w, double h) {
          TextureCanvas c(w, h, 0.02, face == 5 ? 240.0 : grey - 20.0);
          cv::RNG r(MixSeed(seed, 20 + face));
          return c.Finish(0.0, 0.5, 1.0, r);
        });
    if (rng_.uniform(0.0, 1.0) < 0.45) {  // a traffic sign facing the oncoming traffic
      const double size = 0.62, bottom = rng_.uniform(2.1, 2.6);
      const int kind = rng_.uniform(0, 3);
      TextureCanvas c(size, size, 0.005, 235);
      if (kind == 0) {  // prohibition: ring and bar
        c.FillEllipse({size / 2, size / 2}, size / 2 - 0.01, size / 2 - 0.01, 0, 70);
        c.FillEllipse({size / 2, size / 2}, size / 2 - 0.08, size / 2 - 0.08, 0, 238);
        c.FillRect(0.14, 0.27, size - 0.14, 0.35, 40);
      } else if (kind == 1) {  // warning: triangle
        c.FillConvex({{0.03, size - 0.06}, {size - 0.03, size - 0.06}, {size / 2, 0.05}}, 70);
        c.FillConvex({{0.13, size - 0.11}, {size - 0.13, size - 0.11}, {size / 2, 0.2}}, 238);
        c.FillRect(size / 2 - 0.02, 0.28, size / 2 + 0.02, 0.42, 30);
      } else {  // information: square with a symbol
        c.FillRect(0.02, 0.02, size - 0.02, size - 0.02, 60);
        c.FillRect(0.22, 0.12, 0.32, 0.5, 235);
        c.FillEllipse({0.4, 0.24}, 0.09, 0.1, 0, 235);
      }
      cv::RNG r(MixSeed(seed, 40));
      const Vec2 f(std::cos(heading), std::sin(heading));
      // On the side of the post the traffic of its side of the road comes from: before it
      // along the street on the right (side -1), after it on the left.
      const Vec2 a = base + side * 0.09 * f + 0.31 * left, b = a - size * left;
      Quad(At(a, bottom + size), At(b - a, 0), Vec3(0, 0, -size), c.Finish(0.02, 0.3, 1.5, r));
      Edge(At(a, bottom), At(b, bottom));
      Edge(At(a, bottom + size), At(b, bottom + size));
      Edge(At(a, bottom), At(a, bottom + size));
      Edge(At(b, bottom), At(b, bottom + size));
    }
  }
}

void StreetBuilder::Trees(const StreetSpec& st, int side, double s0, double s1, double spacing,
                          double probability) {
  for (double s = s0 + rng_.uniform(0.0, spacing); s < s1; s += spacing * rng_.uniform(0.9, 1.1)) {
    const bool present = rng_.uniform(0.0, 1.0) < probability;
    const double trunk_h = rng_.uniform(2.4, 2.9), crown = rng_.uniform(1.05, 1.35);
    const double crown_h = rng_.uniform(2.4, 3.4), spin = rng_.uniform(0.0, kPi);
    if (!present) continue;
    bool clear = true;
    for (double c : st.crossings) clear = clear && std::abs(s - c) > 4.0;
    if (!clear) continue;
    const Vec2 base = st.centre.Position(s) + side * (st.road_half() + 1.6) * st.centre.Left(s);
    const uint64_t seed = Tag();
    Box(base, spin, 0.14, 0.14, 0.0, trunk_h, 15, [&](int face, double w, double h) {
      TextureCanvas c(w, h, 0.01, 70 + 8 * (face % 2));
      cv::RNG r(MixSeed(seed, face));
      c.AddNoise(18.0, 0.08, 3, 0.6, r);
      return c.Finish(0.05, 0.5, 2.0, r);
    });
    // Crown: leaves as blobs of many greys, a strongly textured block.
    Box(base, spin, crown, crown, trunk_h, trunk_h + crown_h, 63,
        [&](int face, double w, double h) {
          cv::RNG r(MixSeed(seed, 10 + face));
          TextureCanvas c(w, h, 0.02, face == 5 ? 55 : 82);
          const int blobs = static_cast<int>(w * h * 90);
          for (int i = 0; i < blobs; ++i) {
            const double size = std::exp(r.uniform(std::log(0.04), std::log(0.25)));
            c.FillEllipse({r.uniform(0.0, w), r.uniform(0.0, h)}, size, size * r.uniform(0.5, 1.0),
                          r.uniform(0.0, 180.0), r.uniform(30.0, 140.0));
          }
          return c.Finish(0.1, 0.8, 2.0, r);
        });
  }
}

}  // namespace pl_slam::sim::street
