#include "pl_slam/features/line_features.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <sstream>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "line_features_internal.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

// 8-neighbourhood in an image with y down, counter-clockwise from +x.
constexpr int kDirX[8] = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr int kDirY[8] = {0, 1, 1, 1, 0, -1, -1, -1};

// An edge pixel of a chain: linear index, position (sub-pixel once refined) and gradient.
struct EdgePoint {
  int idx;
  float x, y, gx, gy;
};

// A segment before it becomes a LineFeature.
struct RawSegment {
  float x1, y1, x2, y2;
  float Length() const { return std::hypot(x2 - x1, y2 - y1); }
};

// Buffers of one Detect() call. Allocating the image-sized ones per call costs page faults
// (kernel time) on every frame, so LineDetector keeps them in a pool for the next call.
struct Workspace {
  cv::Mat blurred, dx, dy, mag, edges;
  std::vector<int> forward, backward, chain;
  std::vector<EdgePoint> pts;
  std::vector<RawSegment> segs;
  std::vector<uint8_t> covered;  // low-contrast cells: crossed by a first-search segment
  int covered_cols = 0;          // cells per row of `covered`
};

// The cells (cell x cell pixels, row by row) that the segments cross, in ws->covered; true
// when some cell is left uncovered.
bool MarkCoveredCells(const std::vector<RawSegment>& segs, int cell, int rows, int cols,
                      Workspace* ws) {
  const int gc = (cols + cell - 1) / cell, gr = (rows + cell - 1) / cell;
  ws->covered_cols = gc;
  ws->covered.assign(static_cast<size_t>(gc) * gr, 0);
  for (const RawSegment& s : segs) {
    // Samples at most half a cell apart, both endpoints included.
    const int n = 1 + static_cast<int>(std::ceil(2.0f * s.Length() / cell));
    for (int k = 0; k <= n; ++k) {
      const float t = static_cast<float>(k) / n;
      const int x = std::clamp(static_cast<int>(s.x1 + t * (s.x2 - s.x1)), 0, cols - 1);
      const int y = std::clamp(static_cast<int>(s.y1 + t * (s.y2 - s.y1)), 0, rows - 1);
      ws->covered[static_cast<size_t>(y / cell) * gc + x / cell] = 1;
    }
  }
  return std::find(ws->covered.begin(), ws->covered.end(), 0) != ws->covered.end();
}

// Orients s -> e so that the brighter side is on the right (image coordinates, y down),
// given the summed gradient (dark to bright) along the segment: the descriptor and the angle
// then mean the same thing in every image.
void OrientByGradient(float gx, float gy, RawSegment* s) {
  const float cross = (s->x2 - s->x1) * gy - (s->y2 - s->y1) * gx;
  if (cross < 0) {
    std::swap(s->x1, s->x2);
    std::swap(s->y1, s->y2);
  }
}

// Orients a segment found without gradients (LSD) by sampling them along it.
void OrientBySampling(const cv::Mat& dx, const cv::Mat& dy, RawSegment* s) {
  const int samples = std::clamp(static_cast<int>(s->Length() / 2.f), 2, 32);
  float gx = 0, gy = 0;
  for (int k = 0; k < samples; ++k) {
    const float t = (k + 0.5f) / samples;
    const int x = std::clamp(cvRound(s->x1 + t * (s->x2 - s->x1)), 0, dx.cols - 1);
    const int y = std::clamp(cvRound(s->y1 + t * (s->y2 - s->y1)), 0, dx.rows - 1);
    gx += dx.at<int16_t>(y, x);
    gy += dy.at<int16_t>(y, x);
  }
  OrientByGradient(gx, gy, s);
}

// Moves an edge pixel to the vertex of the parabola through the gradient magnitudes across
// the edge (along the image axis closer to the gradient). Integer positions alone would
// quantise near-vertical lines to whole columns, i.e. whole pixels of disparity.
inline void SubPixelEdge(const uint16_t* mag, int stride, EdgePoint* p) {
  const int idx = p->idx;
  const bool across_x = std::abs(p->gx) >= std::abs(p->gy);
  const int o = across_x ? 1 : stride;
  const float m0 = mag[idx];
  const float mm = mag[idx - o];
  const float mp = mag[idx + o];
  const float denom = mm - 2.f * m0 + mp;
  float delta = 0.f;
  if (denom < 0.f) delta = std::clamp(0.5f * (mm - mp) / denom, -0.5f, 0.5f);
  if (across_x) {
    p->x += delta;
  } else {
    p->y += delta;
  }
}

// Total-least-squares line of a growing point set, in coordinates relative to its first
// point (keeps the moments well conditioned in single passes).
class LineFit {
 public:
  explicit LineFit(float ox, float oy) : ox_(ox), oy_(oy) {}
  void Add(float x, float y, double weight = 1.0) {
    const double u = x - ox_, v = y - oy_;
    n_ += weight;
    su_ += weight * u;
    sv_ += weight * v;
    suu_ += weight * u * u;
    suv_ += weight * u * v;
    svv_ += weight * v * v;
    dirty_ = true;
  }
  // Unit direction of the fitted line (the normal turned by 90 deg).
  void Direction(double* dx, double* dy) {
    if (dirty_) Refit();
    *dx = -ny_;
    *dy = nx_;
  }
  // Signed distance of (x, y) to the fitted line.
  double Distance(float x, float y) {
    if (dirty_) Refit();
    return nx_ * (x - ox_ - cu_) + ny_ * (y - oy_ - cv_);
  }
  // Projection of (x, y) onto the fitted line.
  void Project(float x, float y, float* px, float* py) {
    const double d = Distance(x, y);
    *px = static_cast<float>(x - d * nx_);
    *py = static_cast<float>(y - d * ny_);
  }

 private:
  void Refit() {
    cu_ = su_ / n_;
    cv_ = sv_ / n_;
    const double a = suu_ / n_ - cu_ * cu_, b = suv_ / n_ - cu_ * cv_, c = svv_ / n_ - cv_ * cv_;
    // Normal = eigenvector of the smaller eigenvalue of [[a, b], [b, c]].
    const double lambda = 0.5 * (a + c) - std::sqrt(0.25 * (a - c) * (a - c) + b * b);
    double nx = b, ny = lambda - a;
    const double mx = lambda - c, my = b;
    if (nx * nx + ny * ny < mx * mx + my * my) {
      nx = mx;
      ny = my;
    }
    const double norm = std::sqrt(nx * nx + ny * ny);
    if (norm > 0) {
      nx_ = nx / norm;
      ny_ = ny / norm;
    }
    dirty_ = false;
  }

  float ox_, oy_;
  double n_ = 0, su_ = 0, sv_ = 0, suu_ = 0, suv_ = 0, svv_ = 0;
  double cu_ = 0, cv_ = 0, nx_ = 1, ny_ = 0;
  bool dirty_ = true;
};

// Follows an edge from pixel `idx` (already taken), preferring to go straight on; clears
// every pixel it takes so no chain is traced twice.
void Trace(uint8_t* edges, const int* offsets, int idx, int dir, std::vector<int>* chain) {
  static constexpr int kTurns[5] = {0, 1, -1, 2, -2};
  for (;;) {
    int next_dir = -1;
    if (dir < 0) {
      for (int k = 0; k < 8; ++k) {
        if (edges[idx + offsets[k]]) {
          next_dir = k;
          break;
        }
      }
    } else {
      for (int t : kTurns) {
        const int k = (dir + t + 8) & 7;
        if (edges[idx + offsets[k]]) {
          next_dir = k;
          break;
        }
      }
    }
    if (next_dir < 0) return;
    idx += offsets[next_dir];
    edges[idx] = 0;
    chain->push_back(idx);
    dir = next_dir;
  }
}

// A closed contour (a rectangle's outline) is traced from wherever the raster scan met it,
// usually mid-edge just after a corner; the run splitter would then leave the corner's
// pixels at the far end of the chain and that edge would start a few pixels short. Closed
// chains are therefore rotated to start at their sharpest turn.
void RotateClosedChain(int stride, std::vector<int>* chain) {
  std::vector<int>& c = *chain;
  const int n = static_cast<int>(c.size());
  constexpr int kArm = 4;  // pixels on each side of a point to measure the turn
  if (n < 4 * kArm) return;
  const int dfirst = c.front() - c.back();
  const int dyf = (dfirst + stride + 1) / stride - 1;  // row step between last and first (-1..1)
  const int dxf = dfirst - dyf * stride;
  if (std::abs(dyf) > 1 || std::abs(dxf) > 1) return;
  auto xy = [stride](int idx) { return cv::Point(idx % stride, idx / stride); };
  int best = 0;
  double best_cos = 2.0;
  for (int k = 0; k < n; ++k) {
    const cv::Point p = xy(c[k]), a = xy(c[(k - kArm + n) % n]), b = xy(c[(k + kArm) % n]);
    const cv::Point u = p - a, v = b - p;
    const double cosine = u.dot(v) / (std::sqrt(static_cast<double>(u.dot(u)) * v.dot(v)) + 1e-9);
    if (cosine < best_cos) {
      best_cos = cosine;
      best = k;
    }
  }
  std::rotate(c.begin(), c.begin() + best, c.end());
}

// Cuts a chain of edge pixels into straight runs: a run starts where `seed_len` consecutive
// points lie within `tol` of their chord and grows while the next point stays within `tol`
// of the least-squares line of the run so far. Points are refined to sub-pixel positions
// first: splitting on integer positions instead was measured worse (EuRoC: 38 instead of 45
// stereo matches per frame; lower repeatability on the synthetic room).
void SplitChain(const uint16_t* mag, int stride, std::vector<EdgePoint>* chain, float tol,
                int seed_len, float min_len, std::vector<RawSegment>* out) {
  std::vector<EdgePoint>& pts = *chain;
  for (EdgePoint& p : pts) SubPixelEdge(mag, stride, &p);
  const int n = static_cast<int>(pts.size());
  int i = 0;
  int free_from = 0;  // points before this belong to an earlier run
  while (i + seed_len <= n) {
    const EdgePoint& a = pts[i];
    const EdgePoint& b = pts[i + seed_len - 1];
    const float chord = std::hypot(b.x - a.x, b.y - a.y);
    bool straight = chord > 0.5f * seed_len;
    if (straight) {
      const float nx = -(b.y - a.y) / chord, ny = (b.x - a.x) / chord;
      for (int k = i + 1; k < i + seed_len - 1; ++k) {
        if (std::abs(nx * (pts[k].x - a.x) + ny * (pts[k].y - a.y)) > tol) {
          straight = false;
          break;
        }
      }
    }
    if (!straight) {
      ++i;
      continue;
    }
    LineFit fit(a.x, a.y);
    for (int k = i; k < i + seed_len; ++k) fit.Add(pts[k].x, pts[k].y);
    int j = i + seed_len;
    while (j < n && std::abs(fit.Distance(pts[j].x, pts[j].y)) <= tol) {
      fit.Add(pts[j].x, pts[j].y);
      ++j;
    }
    // Points skipped while looking for a straight seed (around a corner) may still lie on
    // the run's line: take them back, or the run would start short of the corner.
    while (i > free_from && std::abs(fit.Distance(pts[i - 1].x, pts[i - 1].y)) <= tol) {
      --i;
      fit.Add(pts[i].x, pts[i].y);
    }
    RawSegment seg;
    fit.Project(pts[i].x, pts[i].y, &seg.x1, &seg.y1);
    fit.Project(pts[j - 1].x, pts[j - 1].y, &seg.x2, &seg.y2);
    if (seg.Length() >= min_len) {
      float gx = 0, gy = 0;
      for (int k = i; k < j; ++k) {
        gx += pts[k].gx;
        gy += pts[k].gy;
      }
      OrientByGradient(gx, gy, &seg);
      out->push_back(seg);
    }
    i = j;
    free_from = j;
  }
}

// L1 gradient magnitude |dx| + |dy| of the whole image (SIMD), the quantity Canny uses.
void GradientMagnitude(const cv::Mat& dx, const cv::Mat& dy, cv::Mat* mag) {
  mag->create(dx.size(), CV_16UC1);
  const int n = static_cast<int>(dx.total());
  const int16_t* px = dx.ptr<int16_t>();
  const int16_t* py = dy.ptr<int16_t>();
  uint16_t* pm = mag->ptr<uint16_t>();
  int i = 0;
  for (; i + cv::v_int16x8::nlanes <= n; i += cv::v_int16x8::nlanes) {
    cv::v_store(pm + i,
                cv::v_add_wrap(cv::v_abs(cv::v_load(px + i)), cv::v_abs(cv::v_load(py + i))));
  }
  for (; i < n; ++i) pm[i] = static_cast<uint16_t>(std::abs(px[i]) + std::abs(py[i]));
}

// Canny's non-maximum suppression without its hysteresis pass: pixels above `low` that are
// maxima across the edge, with the gradient direction quantised to 4 as in Canny (tan 22.5
// in 16-bit fixed point). Hysteresis is applied per chain instead (a chain must reach
// `high`), the same idea at a fraction of the cost. Eight pixels per SIMD step; the 1-pixel
// frame stays empty so that chain tracing never leaves the image.
void NonMaxSuppression(const cv::Mat& dx, const cv::Mat& dy, const cv::Mat& mag, int low,
                       cv::Mat* edges) {
  const int rows = mag.rows, cols = mag.cols, stride = cols;
  edges->create(mag.size(), CV_8UC1);
  edges->setTo(0);
  const int16_t* px = dx.ptr<int16_t>();
  const int16_t* py = dy.ptr<int16_t>();
  const uint16_t* pm = mag.ptr<uint16_t>();
  uint8_t* pe = edges->ptr<uint8_t>();
  constexpr int kTan22 = 27146;  // tan(22.5 deg) * 2^16
  const cv::v_uint16x8 v_low = cv::v_setall_u16(static_cast<uint16_t>(low));
  const cv::v_uint16x8 v_tan22 = cv::v_setall_u16(kTan22);
  const cv::v_int16x8 v_zero = cv::v_setzero_s16();
  for (int y = 1; y < rows - 1; ++y) {
    const int row = y * stride;
    int x = 1;
    for (; x + cv::v_uint16x8::nlanes <= cols - 1; x += cv::v_uint16x8::nlanes) {
      const int i = row + x;
      const cv::v_uint16x8 m = cv::v_load(pm + i);
      const cv::v_uint16x8 strong = m > v_low;
      if (!cv::v_check_any(strong)) continue;
      const cv::v_int16x8 gx = cv::v_load(px + i), gy = cv::v_load(py + i);
      const cv::v_uint16x8 ax = cv::v_abs(gx), ay = cv::v_abs(gy);
      const cv::v_uint16x8 along_x = ay < cv::v_mul_hi(ax, v_tan22);
      const cv::v_uint16x8 along_y = ax < cv::v_mul_hi(ay, v_tan22);
      const cv::v_uint16x8 same_sign = cv::v_reinterpret_as_u16((gx ^ gy) >= v_zero);
      const cv::v_uint16x8 max_x = (m > cv::v_load(pm + i - 1)) & (m >= cv::v_load(pm + i + 1));
      const cv::v_uint16x8 max_y =
          (m > cv::v_load(pm + i - stride)) & (m >= cv::v_load(pm + i + stride));
      // Same signs: the gradient points down-right, neighbours up-left and down-right.
      const cv::v_uint16x8 max_d1 =
          (m > cv::v_load(pm + i - stride - 1)) & (m > cv::v_load(pm + i + stride + 1));
      const cv::v_uint16x8 max_d2 =
          (m > cv::v_load(pm + i - stride + 1)) & (m > cv::v_load(pm + i + stride - 1));
      const cv::v_uint16x8 is_max = cv::v_select(
          along_x, max_x, cv::v_select(along_y, max_y, cv::v_select(same_sign, max_d1, max_d2)));
      const cv::v_uint16x8 edge = is_max & strong;
      cv::v_store_low(pe + i, cv::v_pack_b(edge, edge));
    }
    for (; x < cols - 1; ++x) {
      const int i = row + x;
      const int m = pm[i];
      if (m <= low) continue;
      const int gx = px[i], gy = py[i];
      const int ax = std::abs(gx), ay = std::abs(gy);
      bool is_max;
      if (ay < ((ax * kTan22) >> 16)) {
        is_max = m > pm[i - 1] && m >= pm[i + 1];
      } else if (ax < ((ay * kTan22) >> 16)) {
        is_max = m > pm[i - stride] && m >= pm[i + stride];
      } else {
        const int s = (gx ^ gy) < 0 ? -1 : 1;
        is_max = m > pm[i - stride - s] && m > pm[i + stride + s];
      }
      if (is_max) pe[i] = 255;
    }
  }
}

// Edge pixels (NMS of the shared gradients), chained, cut into straight runs.
// Edge-chain segments of ws->dx, ws->dy appended to ws->segs; with cell > 0 only in the cells
// ws->covered leaves uncovered (MarkCoveredCells).
void DetectEdgeChainSegments(const LineDetectorOptions& opt, float min_piece_len, int cell,
                             Workspace* ws) {
  const cv::Mat& dx = ws->dx;
  const cv::Mat& dy = ws->dy;
  cv::Mat& edges = ws->edges;
  std::vector<RawSegment>* segments = &ws->segs;
  const int rows = dx.rows, cols = dx.cols;
  if (rows < 3 || cols < 3) return;
  CV_Assert(dx.isContinuous() && dy.isContinuous());
  GradientMagnitude(dx, dy, &ws->mag);
  NonMaxSuppression(dx, dy, ws->mag, static_cast<int>(opt.canny_low), &edges);
  if (cell > 0) {
    const int gc = ws->covered_cols;
    for (size_t c = 0; c < ws->covered.size(); ++c) {
      if (!ws->covered[c]) continue;
      const int x0 = static_cast<int>(c % gc) * cell, y0 = static_cast<int>(c / gc) * cell;
      edges(cv::Rect(x0, y0, std::min(cell, cols - x0), std::min(cell, rows - y0))).setTo(0);
    }
  }
  const int stride = cols;
  int offsets[8];
  for (int k = 0; k < 8; ++k) offsets[k] = kDirY[k] * stride + kDirX[k];

  const int16_t* pdx = dx.ptr<int16_t>();
  const int16_t* pdy = dy.ptr<int16_t>();
  const uint16_t* pmag = ws->mag.ptr<uint16_t>();
  const int high = static_cast<int>(opt.canny_high);
  uint8_t* e = edges.ptr<uint8_t>();
  const float tol = static_cast<float>(opt.max_fit_distance);
  // A run must start straight over a few pixels; short enough that short pieces still
  // form, long enough that noise does not seed runs.
  const int seed_len = std::clamp(static_cast<int>(min_piece_len * 0.5f), 5, 15);
  const int min_chain = std::max(seed_len, static_cast<int>(min_piece_len * 0.7f));

  std::vector<int>& forward = ws->forward;
  std::vector<int>& backward = ws->backward;
  std::vector<int>& chain = ws->chain;
  std::vector<EdgePoint>& pts = ws->pts;
  for (int y = 1; y < rows - 1; ++y) {
    const uint8_t* row = e + y * stride;
    for (int x = 1; x < cols - 1; ++x) {
      // Most of the image is not edge: skip it eight pixels at a time.
      uint64_t word;
      if (x + 8 <= cols - 1 && (std::memcpy(&word, row + x, 8), word == 0)) {
        x += 7;
        continue;
      }
      if (!row[x]) continue;
      const int seed = y * stride + x;
      e[seed] = 0;
      forward.clear();
      backward.clear();
      Trace(e, offsets, seed, -1, &forward);
      int back_dir = -1;
      if (!forward.empty()) {
        const int first = forward[0] - seed;
        for (int k = 0; k < 8; ++k) {
          if (offsets[k] == first) back_dir = (k + 4) & 7;
        }
      }
      Trace(e, offsets, seed, back_dir, &backward);
      const int total = static_cast<int>(forward.size() + backward.size()) + 1;
      if (total < min_chain) continue;
      chain.assign(backward.rbegin(), backward.rend());
      chain.push_back(seed);
      chain.insert(chain.end(), forward.begin(), forward.end());
      RotateClosedChain(stride, &chain);
      pts.resize(chain.size());
      int strongest = 0;
      for (size_t k = 0; k < chain.size(); ++k) {
        const int idx = chain[k];
        strongest = std::max<int>(strongest, pmag[idx]);
        pts[k] = {idx, static_cast<float>(idx % stride), static_cast<float>(idx / stride),
                  static_cast<float>(pdx[idx]), static_cast<float>(pdy[idx])};
      }
      if (strongest < high) continue;  // hysteresis: a chain needs one strong pixel
      SplitChain(pmag, stride, &pts, tol, seed_len, min_piece_len, segments);
    }
  }
}

// Adds a piece to `fit` as a uniform run of edge points along it: two points of half its
// length as weight, 1 / sqrt(12) of its length either side of its centre, have its moments.
void AddPiece(const RawSegment& s, LineFit* fit) {
  const double len = s.Length(), k = 0.5 / std::sqrt(3.0);
  const float mx = 0.5f * (s.x1 + s.x2), my = 0.5f * (s.y1 + s.y2);
  const float ex = static_cast<float>(k * (s.x2 - s.x1)),
              ey = static_cast<float>(k * (s.y2 - s.y1));
  fit->Add(mx - ex, my - ey, 0.5 * len);
  fit->Add(mx + ex, my + ey, 0.5 * len);
}

// Joins collinear pieces of one edge that edge detection or the run splitter cut apart
// (junctions, weak spots): same polarity-aware direction, endpoints close to each other's line,
// small gap. Longer pieces absorb shorter ones (again while they grow), and the joined segment
// lies on the least-squares line of all its pieces, spanning their extreme projections.
void MergeCollinear(const LineDetectorOptions& opt, std::vector<RawSegment>* segments) {
  std::vector<RawSegment>& segs = *segments;
  const int n = static_cast<int>(segs.size());
  if (n < 2) return;
  struct Geom {
    float len, ux, uy, angle;
  };
  std::vector<Geom> geom(n);
  auto update = [&](int i) {
    const RawSegment& s = segs[i];
    const float len = s.Length();
    geom[i] = {len, (s.x2 - s.x1) / len, (s.y2 - s.y1) / len, std::atan2(s.y2 - s.y1, s.x2 - s.x1)};
  };
  std::sort(segs.begin(), segs.end(),
            [](const RawSegment& a, const RawSegment& b) { return a.Length() > b.Length(); });
  for (int i = 0; i < n; ++i) update(i);
  // Candidates come from an angle-sorted index, so each piece only meets the few pieces
  // of nearly the same direction instead of all of them.
  std::vector<int> by_angle(n);
  for (int i = 0; i < n; ++i) by_angle[i] = i;
  std::sort(by_angle.begin(), by_angle.end(),
            [&](int a, int b) { return geom[a].angle < geom[b].angle; });
  std::vector<float> sorted_angles(n);
  for (int k = 0; k < n; ++k) sorted_angles[k] = geom[by_angle[k]].angle;

  const float max_angle = static_cast<float>(opt.merge_max_angle_deg * kPi / 180.0);
  const float cos_max = std::cos(max_angle);
  const float max_dist = static_cast<float>(opt.merge_max_distance);
  const float max_gap = static_cast<float>(opt.merge_max_gap);
  const float two_pi = static_cast<float>(2.0 * kPi);
  std::vector<char> alive(n, 1);
  std::vector<int> candidates;
  for (int i = 0; i < n; ++i) {
    if (!alive[i]) continue;
    // A piece absorbs only later (shorter) ones, which have absorbed nothing yet: the fit
    // takes each as one piece.
    LineFit fit(segs[i].x1, segs[i].y1);
    AddPiece(segs[i], &fit);
    // Again while the piece grows: a piece beyond the gap may be within it of the longer one.
    for (bool grew = true; grew;) {
      grew = false;
      candidates.clear();
      const float a0 = geom[i].angle;
      // Window [a0 - max_angle, a0 + max_angle], split where it wraps around +-pi.
      for (float shift : {0.f, -two_pi, two_pi}) {
        const float lo = a0 - max_angle + shift, hi = a0 + max_angle + shift;
        if (hi < -kPi || lo > kPi) continue;
        auto it = std::lower_bound(sorted_angles.begin(), sorted_angles.end(), lo);
        for (; it != sorted_angles.end() && *it <= hi; ++it) {
          const int j = by_angle[it - sorted_angles.begin()];
          if (j > i && alive[j]) candidates.push_back(j);
        }
      }
      std::sort(candidates.begin(), candidates.end());  // longest first
      RawSegment& a = segs[i];
      for (int j : candidates) {
        const RawSegment& b = segs[j];
        const Geom& ga = geom[i];
        const Geom& gb = geom[j];
        if (ga.ux * gb.ux + ga.uy * gb.uy < cos_max) continue;
        const float d1 = -ga.uy * (b.x1 - a.x1) + ga.ux * (b.y1 - a.y1);
        const float d2 = -ga.uy * (b.x2 - a.x1) + ga.ux * (b.y2 - a.y1);
        if (std::abs(d1) > max_dist || std::abs(d2) > max_dist) continue;
        const float t1 = ga.ux * (b.x1 - a.x1) + ga.uy * (b.y1 - a.y1);
        const float t2 = ga.ux * (b.x2 - a.x1) + ga.uy * (b.y2 - a.y1);
        const float gap = std::max(std::min(t1, t2) - ga.len, -std::max(t1, t2));
        if (gap > max_gap) continue;
        // The least-squares line through every piece absorbed so far, each taken as a uniform
        // run of edge points; endpoints = extreme projections. Averaging the pieces' own
        // directions instead tilts the joined line (a dashed edge of 30 px pieces: 0.5 deg, its
        // ends 0.6 px off), and stereo turns an offset across a segment into 1 / sin(angle to
        // the rows) times as much disparity error.
        AddPiece(b, &fit);
        double dx_d, dy_d;
        fit.Direction(&dx_d, &dy_d);
        if (dx_d * ga.ux + dy_d * ga.uy < 0.0) {  // keep the polarity-aware direction
          dx_d = -dx_d;
          dy_d = -dy_d;
        }
        const float dx = static_cast<float>(dx_d), dy = static_cast<float>(dy_d);
        float cx, cy;  // a point of the line
        fit.Project(a.x1, a.y1, &cx, &cy);
        const float ts[4] = {
            dx * (a.x1 - cx) + dy * (a.y1 - cy), dx * (a.x2 - cx) + dy * (a.y2 - cy),
            dx * (b.x1 - cx) + dy * (b.y1 - cy), dx * (b.x2 - cx) + dy * (b.y2 - cy)};
        const float tmin = *std::min_element(ts, ts + 4), tmax = *std::max_element(ts, ts + 4);
        a = {cx + tmin * dx, cy + tmin * dy, cx + tmax * dx, cy + tmax * dy};
        alive[j] = 0;
        update(i);
        grew = true;
      }
    }
  }
  int out = 0;
  for (int i = 0; i < n; ++i) {
    if (alive[i]) segs[out++] = segs[i];
  }
  segs.resize(out);
}

void DetectLsdSegments(const cv::Mat& image, const cv::Mat& dx, const cv::Mat& dy,
                       const LineDetectorOptions& opt, float min_len,
                       std::vector<RawSegment>* segments) {
  // One LSD object per call: its detect() keeps per-image state in members.
  cv::Ptr<cv::LineSegmentDetector> lsd =
      cv::createLineSegmentDetector(cv::LSD_REFINE_NONE, opt.lsd_scale);
  std::vector<cv::Vec4f> lines;
  lsd->detect(image, lines);
  for (const cv::Vec4f& l : lines) {
    RawSegment s{l[0], l[1], l[2], l[3]};
    if (s.Length() < min_len) continue;
    OrientBySampling(dx, dy, &s);
    segments->push_back(s);
  }
}

}  // namespace

std::string LineDetectorOptions::Validate() const {
  std::ostringstream os;
  if (!(min_length_ratio > 0.0 && min_length_ratio <= 0.5)) {
    os << "min_length_ratio=" << min_length_ratio << " must be in (0, 0.5]";
  } else if (max_lines < 0 || max_lines > 10000) {
    os << "max_lines=" << max_lines << " must be in [0, 10000]";
  } else if (!(prefer_steep_deg >= 0.0 && prefer_steep_deg <= 45.0)) {
    os << "prefer_steep_deg=" << prefer_steep_deg << " must be in [0, 45]";
  } else if (!(canny_low > 0.0 && canny_low <= 2000.0)) {
    os << "canny_low=" << canny_low << " must be in (0, 2000]";
  } else if (!(canny_high >= canny_low && canny_high <= 2000.0)) {
    os << "canny_high=" << canny_high << " must be in [canny_low, 2000]";
  } else if (min_lines < 0 || min_lines > 10000) {
    os << "min_lines=" << min_lines << " must be in [0, 10000]";
  } else if (low_contrast_cell != 0 && (low_contrast_cell < 16 || low_contrast_cell > 4096)) {
    os << "low_contrast_cell=" << low_contrast_cell << " must be 0 or in [16, 4096]";
  } else if (!(low_contrast_canny_low > 0.0 && low_contrast_canny_low <= 2000.0)) {
    os << "low_contrast_canny_low=" << low_contrast_canny_low << " must be in (0, 2000]";
  } else if (!(low_contrast_canny_high >= low_contrast_canny_low &&
               low_contrast_canny_high <= 2000.0)) {
    os << "low_contrast_canny_high=" << low_contrast_canny_high
       << " must be in [low_contrast_canny_low, 2000]";
  } else if (!(max_fit_distance >= 0.2 && max_fit_distance <= 5.0)) {
    os << "max_fit_distance=" << max_fit_distance << " must be in [0.2, 5]";
  } else if (!(merge_max_gap >= 0.0 && merge_max_gap <= 100.0)) {
    os << "merge_max_gap=" << merge_max_gap << " must be in [0, 100]";
  } else if (!(merge_max_distance >= 0.0 && merge_max_distance <= 10.0)) {
    os << "merge_max_distance=" << merge_max_distance << " must be in [0, 10]";
  } else if (!(merge_max_angle_deg >= 0.0 && merge_max_angle_deg <= 20.0)) {
    os << "merge_max_angle_deg=" << merge_max_angle_deg << " must be in [0, 20]";
  } else if (!(lsd_scale > 0.0 && lsd_scale <= 1.0)) {
    os << "lsd_scale=" << lsd_scale << " must be in (0, 1]";
  }
  return os.str();
}

// Idle workspaces: a call takes one (or makes one) and gives it back, so concurrent calls
// never share buffers and the pool holds one workspace per concurrent caller. Per-thread
// storage would instead start from scratch on every new thread (std::async makes one per call).
struct LineDetector::WorkspacePool {
  std::mutex mutex;
  std::vector<std::unique_ptr<Workspace>> idle;
};

namespace {

// A workspace borrowed from the pool for the duration of one call.
class WorkspaceLease {
 public:
  explicit WorkspaceLease(LineDetector::WorkspacePool* pool) : pool_(pool) {
    {
      std::lock_guard<std::mutex> lock(pool_->mutex);
      if (!pool_->idle.empty()) {
        ws_ = std::move(pool_->idle.back());
        pool_->idle.pop_back();
      }
    }
    if (!ws_) ws_ = std::make_unique<Workspace>();
  }
  ~WorkspaceLease() {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    pool_->idle.push_back(std::move(ws_));
  }
  WorkspaceLease(const WorkspaceLease&) = delete;
  WorkspaceLease& operator=(const WorkspaceLease&) = delete;
  Workspace& operator*() { return *ws_; }

 private:
  LineDetector::WorkspacePool* pool_;
  std::unique_ptr<Workspace> ws_;
};

}  // namespace

LineDetector::LineDetector(const LineDetectorOptions& options)
    : options_(options), pool_(std::make_shared<WorkspacePool>()) {
  const std::string err = options_.Validate();
  if (!err.empty()) throw ConfigError("lines." + err);
}

LineFeature MakeLineFeature(const Eigen::Vector2d& s, const Eigen::Vector2d& e) {
  LineFeature f;
  f.s = s;
  f.e = e;
  const Eigen::Vector3d l =
      Eigen::Vector3d(s.x(), s.y(), 1.0).cross(Eigen::Vector3d(e.x(), e.y(), 1.0));
  f.l = l / std::hypot(l.x(), l.y());
  f.angle = std::atan2(e.y() - s.y(), e.x() - s.x());
  f.length = (e - s).norm();
  return f;
}

void LineDetector::Detect(const cv::Mat& image, LineFeatures* lines, cv::Mat* descriptors) const {
  lines->clear();
  *descriptors = cv::Mat(0, 32, CV_8UC1);
  if (image.empty()) return;
  if (image.type() != CV_8UC1) {
    throw InputError("LineDetector::Detect: image must be CV_8UC1, got type " +
                     std::to_string(image.type()));
  }
  const float min_len =
      static_cast<float>(options_.min_length_ratio * std::min(image.cols, image.rows));
  WorkspaceLease lease(pool_.get());
  Workspace& ws = *lease;
  line_internal::ComputeGradients(image, &ws.blurred, &ws.dx, &ws.dy);
  const cv::Mat& dx = ws.dx;
  const cv::Mat& dy = ws.dy;
  std::vector<RawSegment>& segs = ws.segs;
  segs.clear();
  // With merging, pieces down to half the minimum length may still add up to a kept line.
  const float piece_len = options_.merge_collinear ? 0.5f * min_len : min_len;
  if (options_.detector == LineDetectorKind::kEdgeChain) {
    DetectEdgeChainSegments(options_, piece_len, 0, &ws);
    const auto kept = std::count_if(
        segs.begin(), segs.end(), [min_len](const RawSegment& r) { return r.Length() >= min_len; });
    LineDetectorOptions low = options_;
    low.canny_low = options_.low_contrast_canny_low;
    low.canny_high = options_.low_contrast_canny_high;
    const bool lower = options_.low_contrast_canny_high < options_.canny_high;
    if (lower && kept < options_.min_lines) {
      // Low contrast: the same search at thresholds just above the image noise. Its segments
      // include the strong ones, so they replace the first search's.
      segs.clear();
      DetectEdgeChainSegments(low, piece_len, 0, &ws);
    } else if (lower && options_.low_contrast_cell > 0 &&
               (options_.max_lines == 0 || kept < options_.max_lines) &&
               MarkCoveredCells(segs, options_.low_contrast_cell, image.rows, image.cols, &ws)) {
      // Enough segments, but only where the image has contrast: where the first search found
      // none, the low-contrast search adds its own. Not when the first search already fills
      // the cap (a street): faint segments would only displace stronger ones.
      DetectEdgeChainSegments(low, piece_len, options_.low_contrast_cell, &ws);
    }
  } else {
    DetectLsdSegments(image, dx, dy, options_, piece_len, &segs);
  }
  if (options_.merge_collinear) MergeCollinear(options_, &segs);

  segs.erase(std::remove_if(segs.begin(), segs.end(),
                            [min_len](const RawSegment& s) { return s.Length() < min_len; }),
             segs.end());
  auto longer = [](const RawSegment& a, const RawSegment& b) { return a.Length() > b.Length(); };
  if (options_.max_lines > 0 && static_cast<int>(segs.size()) > options_.max_lines) {
    // Segments nearly parallel to the rows get no stereo depth (see MatchStereoLines), so
    // they cannot constrain the motion: when the cap bites, steeper segments come first.
    const double flat_tan = std::tan(options_.prefer_steep_deg * M_PI / 180.0);
    auto flat = [flat_tan](const RawSegment& r) {
      return std::abs(r.y2 - r.y1) < flat_tan * std::abs(r.x2 - r.x1);
    };
    auto better = [&](const RawSegment& a, const RawSegment& b) {
      const bool fa = flat(a), fb = flat(b);
      return fa != fb ? fb : a.Length() > b.Length();
    };
    std::nth_element(segs.begin(), segs.begin() + options_.max_lines, segs.end(), better);
    segs.resize(options_.max_lines);
  }
  std::sort(segs.begin(), segs.end(), longer);

  lines->reserve(segs.size());
  for (const RawSegment& s : segs) {
    lines->push_back(MakeLineFeature(Eigen::Vector2d(s.x1, s.y1), Eigen::Vector2d(s.x2, s.y2)));
  }
  if (!lines->empty()) line_internal::LbdFromGradients(dx, dy, *lines, descriptors);
}

}  // namespace pl_slam
