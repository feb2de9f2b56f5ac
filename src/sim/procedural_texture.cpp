#include "pl_slam/sim/procedural_texture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace pl_slam::sim {
namespace {

// Sub-texel precision of OpenCV drawing: coordinates are passed as fixed point with this many
// fractional bits, so shape edges land where the metric description puts them.
constexpr int kShiftBits = 4;
constexpr double kShiftScale = 1 << kShiftBits;

double LogUniform(cv::RNG& rng, double lo, double hi) {
  return std::exp(rng.uniform(std::log(lo), std::log(hi)));
}

// A random shape of size ~`size` metres centred at (x, y): the mix of rectangles, polygons,
// ellipses and strokes gives corners, blobs and edges at many scales.
void DrawRandomShape(TextureCanvas* c, cv::RNG& rng, double x, double y, double size) {
  const double grey = rng.uniform(0.0, 255.0);
  const int kind = rng.uniform(0, 100);
  if (kind < 30) {  // axis-aligned rectangle, sometimes with an outline
    const double w = size * rng.uniform(0.4, 1.0);
    const double h = size * rng.uniform(0.4, 1.0);
    c->FillRect(x - w / 2, y - h / 2, x + w / 2, y + h / 2, grey);
    if (rng.uniform(0, 3) == 0) {
      c->FrameRect(x - w / 2, y - h / 2, x + w / 2, y + h / 2, std::max(0.004, 0.06 * size),
                   rng.uniform(0.0, 255.0));
    }
  } else if (kind < 50) {  // rotated rectangle
    const double w = size * rng.uniform(0.3, 1.0) / 2;
    const double h = size * rng.uniform(0.3, 1.0) / 2;
    const double a = rng.uniform(0.0, CV_PI);
    const cv::Point2d ex(std::cos(a) * w, std::sin(a) * w);
    const cv::Point2d ey(-std::sin(a) * h, std::cos(a) * h);
    const cv::Point2d p(x, y);
    c->FillConvex({p - ex - ey, p + ex - ey, p + ex + ey, p - ex + ey}, grey);
  } else if (kind < 65) {  // ellipse (blob)
    c->FillEllipse({x, y}, size * rng.uniform(0.2, 0.5), size * rng.uniform(0.2, 0.5),
                   rng.uniform(0.0, 180.0), grey);
  } else if (kind < 80) {  // triangle
    std::vector<cv::Point2d> tri;
    const double a0 = rng.uniform(0.0, 2 * CV_PI);
    for (int i = 0; i < 3; ++i) {
      const double a = a0 + i * 2.0 * CV_PI / 3.0 + rng.uniform(-0.5, 0.5);
      const double r = size * rng.uniform(0.3, 0.6);
      tri.emplace_back(x + r * std::cos(a), y + r * std::sin(a));
    }
    c->FillConvex(tri, grey);
  } else if (kind < 93) {  // stroke
    const double a = rng.uniform(0.0, CV_PI);
    const double l = size * rng.uniform(0.8, 2.0) / 2;
    const cv::Point2d d(std::cos(a) * l, std::sin(a) * l);
    c->Line(cv::Point2d(x, y) - d, cv::Point2d(x, y) + d,
            std::max(0.004, size * rng.uniform(0.03, 0.12)), grey);
  } else {  // small checkerboard patch
    const int n = rng.uniform(2, 5);
    const double cell = size / n;
    const double g2 = rng.uniform(0.0, 255.0);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const double x0 = x - size / 2 + i * cell;
        const double y0 = y - size / 2 + j * cell;
        c->FillRect(x0, y0, x0 + cell, y0 + cell, (i + j) % 2 ? grey : g2);
      }
    }
  }
}

void DrawShapes(TextureCanvas* c, cv::RNG& rng, double per_m2, double min_size, double max_size) {
  const int n = static_cast<int>(std::round(per_m2 * c->width_m() * c->height_m()));
  for (int i = 0; i < n; ++i) {
    const double x = rng.uniform(0.0, c->width_m());
    const double y = rng.uniform(0.0, c->height_m());
    DrawRandomShape(c, rng, x, y, LogUniform(rng, min_size, max_size));
  }
}

// A framed poster with dense small content: a strongly textured landmark that helps place
// recognition the way posters do in real rooms.
void DrawPoster(TextureCanvas* c, cv::RNG& rng) {
  const double w = rng.uniform(0.4, 1.1);
  const double h = rng.uniform(0.4, 0.9);
  if (w >= c->width_m() || h >= c->height_m()) return;
  const double x0 = rng.uniform(0.0, c->width_m() - w);
  const double y0 = rng.uniform(0.0, c->height_m() - h);
  c->FillRect(x0, y0, x0 + w, y0 + h, rng.uniform(150.0, 250.0));
  const int n = static_cast<int>(w * h * 120);
  for (int i = 0; i < n; ++i) {
    const double s = LogUniform(rng, 0.02, 0.12);
    const double x = rng.uniform(x0 + s / 2, x0 + w - s / 2);
    const double y = rng.uniform(y0 + s / 2, y0 + h - s / 2);
    DrawRandomShape(c, rng, x, y, s);
  }
  c->FrameRect(x0, y0, x0 + w, y0 + h, 0.02, rng.uniform(0.0, 60.0));
}

}  // namespace

uint64_t MixSeed(uint64_t a, uint64_t b) {
  uint64_t z = a + 0x9E3779B97F4A7C15ULL * (b + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

cv::Mat FractalNoise(cv::Size size, double cell_texels, int octaves, double persistence,
                     cv::RNG& rng) {
  cv::Mat sum = cv::Mat::zeros(size, CV_32F);
  double amplitude = 1.0;
  for (int k = 0; k < octaves; ++k) {
    const double cell = std::max(1.0, cell_texels / static_cast<double>(1 << k));
    // Two extra cells on each side keep the bicubic border effects out of the crop.
    const int gw = static_cast<int>(std::ceil(size.width / cell)) + 4;
    const int gh = static_cast<int>(std::ceil(size.height / cell)) + 4;
    cv::Mat grid(gh, gw, CV_32F);
    rng.fill(grid, cv::RNG::UNIFORM, -1.0, 1.0);
    cv::Mat up;
    if (cell > 1.0) {
      cv::resize(grid, up,
                 cv::Size(static_cast<int>(std::round(gw * cell)),
                          static_cast<int>(std::round(gh * cell))),
                 0, 0, cv::INTER_CUBIC);
    } else {
      up = grid;
    }
    const int ox = std::min(static_cast<int>(2 * cell), up.cols - size.width);
    const int oy = std::min(static_cast<int>(2 * cell), up.rows - size.height);
    cv::scaleAdd(up(cv::Rect(ox, oy, size.width, size.height)), amplitude, sum, sum);
    amplitude *= persistence;
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(sum, mean, stddev);
  sum -= mean[0];
  if (stddev[0] > 0.0) sum *= 1.0 / stddev[0];
  return sum;
}

TextureCanvas::TextureCanvas(double width_m, double height_m, double texel_m, double grey)
    : width_m_(width_m), height_m_(height_m), texel_m_(texel_m) {
  if (!(width_m > 0.0) || !(height_m > 0.0) || !(texel_m > 0.0)) {
    throw std::invalid_argument("TextureCanvas: sizes must be positive");
  }
  const int w = std::max(2, static_cast<int>(std::round(width_m / texel_m)));
  const int h = std::max(2, static_cast<int>(std::round(height_m / texel_m)));
  albedo_ = cv::Mat(h, w, CV_8UC1, cv::Scalar(grey));
}

cv::Point TextureCanvas::ToFixed(const cv::Point2d& p_m) const {
  // Texel i is centred at continuous coordinate i + 0.5 (Texture), OpenCV draws with
  // integer pixel centres: hence the half-texel shift.
  const double x = p_m.x * albedo_.cols / width_m_ - 0.5;
  const double y = p_m.y * albedo_.rows / height_m_ - 0.5;
  auto fixed = [](double v) {
    return static_cast<int>(std::round(std::clamp(v, -1e6, 1e6) * kShiftScale));
  };
  return {fixed(x), fixed(y)};
}

void TextureCanvas::AddNoise(double amplitude, double cell_m, int octaves, double persistence,
                             cv::RNG& rng, double stretch_x) {
  const double cell = cell_m * albedo_.rows / height_m_;
  cv::Mat noise;
  if (stretch_x > 1.0) {
    const cv::Size small(std::max(2, static_cast<int>(albedo_.cols / stretch_x)), albedo_.rows);
    cv::resize(FractalNoise(small, cell, octaves, persistence, rng), noise, albedo_.size(), 0, 0,
               cv::INTER_LINEAR);
  } else {
    noise = FractalNoise(albedo_.size(), cell, octaves, persistence, rng);
  }
  cv::Mat f;
  albedo_.convertTo(f, CV_32F);
  cv::scaleAdd(noise, amplitude, f, f);
  f.convertTo(albedo_, CV_8U);
}

void TextureCanvas::FillRect(double x0, double y0, double x1, double y1, double grey) {
  FillConvex({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, grey);
}

void TextureCanvas::FillConvex(const std::vector<cv::Point2d>& points, double grey) {
  std::vector<cv::Point> fixed;
  fixed.reserve(points.size());
  for (const cv::Point2d& p : points) fixed.push_back(ToFixed(p));
  cv::fillConvexPoly(albedo_, fixed, cv::Scalar(grey), cv::LINE_AA, kShiftBits);
}

void TextureCanvas::FillEllipse(const cv::Point2d& centre, double ax, double ay, double angle_deg,
                                double grey) {
  const double sx = albedo_.cols / width_m_ * kShiftScale;
  const double sy = albedo_.rows / height_m_ * kShiftScale;
  const cv::Size axes(std::max(1, static_cast<int>(std::round(ax * sx))),
                      std::max(1, static_cast<int>(std::round(ay * sy))));
  cv::ellipse(albedo_, ToFixed(centre), axes, angle_deg, 0.0, 360.0, cv::Scalar(grey), cv::FILLED,
              cv::LINE_AA, kShiftBits);
}

void TextureCanvas::Line(const cv::Point2d& a, const cv::Point2d& b, double thickness_m,
                         double grey) {
  // Drawn as a polygon: cv::line's thickness is whole pixels, too coarse for thin strokes.
  const cv::Point2d d = b - a;
  const double len = std::hypot(d.x, d.y);
  if (len <= 0.0) return;
  const cv::Point2d n(-d.y / len * thickness_m / 2, d.x / len * thickness_m / 2);
  FillConvex({a + n, b + n, b - n, a - n}, grey);
}

void TextureCanvas::FrameRect(double x0, double y0, double x1, double y1, double thickness_m,
                              double grey) {
  const double t = thickness_m;
  FillRect(x0, y0, x1, y0 + t, grey);
  FillRect(x0, y1 - t, x1, y1, grey);
  FillRect(x0, y0, x0 + t, y1, grey);
  FillRect(x1 - t, y0, x1, y1, grey);
}

std::shared_ptr<const Texture> TextureCanvas::Finish(double shading_amplitude,
                                                     double shading_cell_m, double grain_sigma,
                                                     cv::RNG& rng) const {
  cv::Mat f;
  albedo_.convertTo(f, CV_32F);
  if (shading_amplitude > 0.0) {
    const double cell = shading_cell_m * albedo_.rows / height_m_;
    cv::Mat shading = FractalNoise(albedo_.size(), cell, 3, 0.5, rng);
    shading = 1.0 + shading_amplitude * shading;
    f = f.mul(shading);
  }
  if (grain_sigma > 0.0) {
    cv::Mat grain(f.size(), CV_32F);
    rng.fill(grain, cv::RNG::NORMAL, 0.0, grain_sigma);
    f += grain;
  }
  return std::make_shared<const Texture>(f);
}

std::shared_ptr<const Texture> MakeSurfaceTexture(SurfaceStyle style, double width_m,
                                                  double height_m, double texel_m, double base_grey,
                                                  uint64_t seed) {
  cv::RNG rng(MixSeed(seed, 0x7e57));
  TextureCanvas c(width_m, height_m, texel_m, base_grey);
  const double area = width_m * height_m;
  switch (style) {
    case SurfaceStyle::kClutter: {
      c.AddNoise(26.0, 0.3, 5, 0.55, rng);
      const int posters = static_cast<int>(std::round(area * 0.12));
      for (int i = 0; i < posters; ++i) DrawPoster(&c, rng);
      DrawShapes(&c, rng, 20.0, 0.03, 0.35);
      return c.Finish(0.06, 1.5, 2.0, rng);
    }
    case SurfaceStyle::kFloorTiles: {
      const double tile = 0.5;
      for (double y = 0.0; y < height_m; y += tile) {
        for (double x = 0.0; x < width_m; x += tile) {
          c.FillRect(x, y, x + tile, y + tile, base_grey + rng.uniform(-35.0, 35.0));
        }
      }
      c.AddNoise(14.0, 0.15, 4, 0.6, rng);
      for (double y = tile; y < height_m; y += tile) c.Line({0, y}, {width_m, y}, 0.008, 40);
      for (double x = tile; x < width_m; x += tile) c.Line({x, 0}, {x, height_m}, 0.008, 40);
      DrawShapes(&c, rng, 4.0, 0.03, 0.2);
      return c.Finish(0.05, 2.0, 2.0, rng);
    }
    case SurfaceStyle::kCeiling: {
      c.AddNoise(10.0, 0.5, 4, 0.5, rng);
      for (double y = 1.0; y + 0.6 < height_m; y += 2.0) {
        for (double x = 1.0; x + 0.6 < width_m; x += 2.0) {
          c.FillRect(x, y, x + 0.6, y + 0.6, 250);
          c.FrameRect(x, y, x + 0.6, y + 0.6, 0.03, 120);
        }
      }
      DrawShapes(&c, rng, 5.0, 0.03, 0.25);
      return c.Finish(0.04, 2.0, 2.0, rng);
    }
    case SurfaceStyle::kWood: {
      for (double y = 0.0; y < height_m;) {
        const double h = rng.uniform(0.08, 0.16);
        c.FillRect(0, y, width_m, y + h, base_grey + rng.uniform(-40.0, 40.0));
        y += h;
        c.Line({0, y}, {width_m, y}, 0.005, 35);
      }
      c.AddNoise(16.0, 0.05, 4, 0.6, rng, 12.0);
      DrawShapes(&c, rng, 6.0, 0.03, 0.2);
      return c.Finish(0.05, 1.0, 2.0, rng);
    }
  }
  throw std::invalid_argument("MakeSurfaceTexture: unknown style");
}

}  // namespace pl_slam::sim
