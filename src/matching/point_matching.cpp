#include "pl_slam/matching/point_matching.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "row_search.h"

namespace pl_slam {

std::string PointMatchingOptions::Validate() const {
  std::ostringstream os;
  if (max_distance < 1 || max_distance > 256)
    os << "max_distance=" << max_distance << " must be in [1, 256]";
  else if (!(stereo_ratio > 0.0 && stereo_ratio <= 1.0))
    os << "stereo_ratio=" << stereo_ratio << " must be in (0, 1]";
  else if (!(stereo_row_tolerance >= 0.0 && stereo_row_tolerance <= 10.0))
    os << "stereo_row_tolerance=" << stereo_row_tolerance << " must be in [0, 10]";
  else if (!(min_disparity >= 0.0 && min_disparity < max_disparity))
    os << "min_disparity=" << min_disparity << " must be in [0, max_disparity)";
  else if (!(max_disparity > 0.0 && max_disparity <= 1000.0))
    os << "max_disparity=" << max_disparity << " must be in (0, 1000]";
  else if (!(f2f_ratio > 0.0 && f2f_ratio <= 1.0))
    os << "f2f_ratio=" << f2f_ratio << " must be in (0, 1]";
  else if (!(search_radius > 0.0 && search_radius <= 1000.0))
    os << "search_radius=" << search_radius << " must be in (0, 1000]";
  else if (!(f2f_align_max_shift >= 0.0 && f2f_align_max_shift <= 10.0))
    os << "f2f_align_max_shift=" << f2f_align_max_shift << " must be in [0, 10]";
  else if (!(same_corner_radius >= 0.0 && same_corner_radius <= 20.0))
    os << "same_corner_radius=" << same_corner_radius << " must be in [0, 20]";
  else if (row_search_below < 0)
    os << "row_search_below=" << row_search_below << " must be >= 0";
  else if (!(row_search_min_zncc >= 0.0 && row_search_min_zncc <= 1.0))
    os << "row_search_min_zncc=" << row_search_min_zncc << " must be in [0, 1]";
  else if (!(row_search_margin >= 0.0 && row_search_margin <= 2.0))
    os << "row_search_margin=" << row_search_margin << " must be in [0, 2]";
  else if (!(stereo_min_zncc >= 0.0 && stereo_min_zncc <= 1.0))
    os << "stereo_min_zncc=" << stereo_min_zncc << " must be in [0, 1]";
  return os.str();
}

int HammingDistance32(const uint8_t* a, const uint8_t* b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a, 32);
  std::memcpy(y, b, 32);
  return __builtin_popcountll(x[0] ^ y[0]) + __builtin_popcountll(x[1] ^ y[1]) +
         __builtin_popcountll(x[2] ^ y[2]) + __builtin_popcountll(x[3] ^ y[3]);
}

namespace {

/// Gauss-Newton on the right-image column x (real) matching left column u0 on row v0: minimises
/// the squared difference of the zero-mean (2 half + 1)^2 patches, the right one sampled by
/// linear interpolation along the row, with interpolated central-difference gradients.
/// Returns false (x unchanged) when it leaves the image, has no gradient, or moves more than
/// half a pixel from where it started.
bool RefineColumnLucasKanade(const cv::Mat& left, const cv::Mat& right, int u0, int v0, int half,
                             double* x) {
  const int n = 2 * half + 1;
  double left_patch[32 * 32];
  if (n > 32) return false;
  double mean_left = 0.0;
  for (int dy = -half; dy <= half; ++dy) {
    const uint8_t* lp = left.ptr<uint8_t>(v0 + dy) + u0 - half;
    for (int dx = 0; dx < n; ++dx) {
      left_patch[(dy + half) * n + dx] = lp[dx];
      mean_left += lp[dx];
    }
  }
  mean_left /= n * n;
  const double start = *x;
  double xc = start;
  for (int iter = 0; iter < 10; ++iter) {
    const int xi = static_cast<int>(std::floor(xc));
    const double a = xc - xi;
    // Samples at xi - half .. xi + half + 1, gradients need one more column on each side.
    if (xi - half - 1 < 0 || xi + half + 2 >= right.cols) return false;
    double sum_v = 0.0, sum_g = 0.0, sum_gl = 0.0, sum_gv = 0.0, sum_gg = 0.0;
    for (int dy = -half; dy <= half; ++dy) {
      const uint8_t* rp = right.ptr<uint8_t>(v0 + dy);
      for (int dx = 0; dx < n; ++dx) {
        const int c = xi - half + dx;
        const double v = (1.0 - a) * rp[c] + a * rp[c + 1];
        const double g0 = 0.5 * (rp[c + 1] - rp[c - 1]), g1 = 0.5 * (rp[c + 2] - rp[c]);
        const double g = (1.0 - a) * g0 + a * g1;
        const double l = left_patch[(dy + half) * n + dx];
        sum_v += v;
        sum_g += g;
        sum_gl += g * l;
        sum_gv += g * v;
        sum_gg += g * g;
      }
    }
    // Residual r = (v - mean v) - (l - mean l), Jacobian J = g - mean g.
    const double m = n * n;
    const double jj = sum_gg - sum_g * sum_g / m;
    if (!(jj > 1e-6)) return false;
    // sum J r = sum (g - mean g) (v - mean v) - sum (g - mean g) (l - mean l).
    const double mean_v = sum_v / m, mean_g = sum_g / m;
    const double jr = (sum_gv - m * mean_g * mean_v) - (sum_gl - mean_g * mean_left * m);
    const double step = -jr / jj;
    xc += step;
    if (std::abs(xc - start) > 0.5) return false;
    if (std::abs(step) < 1e-4) break;
  }
  *x = xc;
  return true;
}

using match_internal::kStereoPatchHalf;

/// Refines the right-image column of a stereo match by SAD over an 11x11 window along the row,
/// with a parabola through the best cost and its neighbours. Returns false when the minimum is
/// on the search border or the fit is implausible (the coarse match is then kept).
bool RefineDisparity(const cv::Mat& left, const cv::Mat& right, double ul, double vl, double* ur) {
  constexpr int kHalf = kStereoPatchHalf, kSearch = 3;
  const int u0 = static_cast<int>(std::lround(ul)), v0 = static_cast<int>(std::lround(vl));
  const int ur0 = static_cast<int>(std::lround(*ur));
  if (v0 - kHalf < 0 || v0 + kHalf >= left.rows || u0 - kHalf < 0 || u0 + kHalf >= left.cols)
    return false;
  if (ur0 - kHalf - kSearch < 0 || ur0 + kHalf + kSearch >= right.cols) return false;
  const int lc = left.at<uint8_t>(v0, u0);
  int cost[2 * kSearch + 1];
  for (int d = -kSearch; d <= kSearch; ++d) {
    const int rc = right.at<uint8_t>(v0, ur0 + d);
    int sad = 0;
    for (int dy = -kHalf; dy <= kHalf; ++dy) {
      const uint8_t* lp = left.ptr<uint8_t>(v0 + dy) + u0 - kHalf;
      const uint8_t* rp = right.ptr<uint8_t>(v0 + dy) + ur0 + d - kHalf;
      // Each patch relative to its centre: robust to a brightness offset between the cameras.
      for (int dx = 0; dx < 2 * kHalf + 1; ++dx) sad += std::abs((lp[dx] - lc) - (rp[dx] - rc));
    }
    cost[d + kSearch] = sad;
  }
  const int best = static_cast<int>(std::min_element(cost, cost + 2 * kSearch + 1) - cost);
  if (best == 0 || best == 2 * kSearch) return false;
  const double c0 = cost[best - 1], c1 = cost[best], c2 = cost[best + 1];
  const double denom = 2.0 * (c0 + c2 - 2.0 * c1);
  if (denom <= 0.0) return false;
  const double delta = (c0 - c2) / denom;
  if (delta < -1.0 || delta > 1.0) return false;
  // A parabola through SAD costs pulls the result towards whole pixels (by up to ~0.07 px at
  // quarter pixels on the synthetic room: a depth error that depends on the depth), so the
  // column is refined further by Gauss-Newton on the intensities (1-D Lucas-Kanade, zero-mean
  // patches, linear interpolation along the row). Kept when it converges within half a pixel.
  double x = ur0 + (best - kSearch) + delta;
  RefineColumnLucasKanade(left, right, u0, v0, kHalf, &x);
  // The patches were compared at the rounded left column u0: carry its offset to the right.
  *ur = x + (ul - u0);
  return true;
}

/// Zero-mean normalised cross-correlation of the 11x11 patch around left pixel (u0, v0) with the
/// right image's patch at column x (linear interpolation along the row); -1 where either patch
/// leaves the image or is flat.
double StereoPatchZncc(const cv::Mat& left, const cv::Mat& right, int u0, int v0, double x) {
  constexpr int kHalf = kStereoPatchHalf, n = 2 * kHalf + 1;
  const int xi = static_cast<int>(std::floor(x));
  const double a = x - xi;
  if (v0 - kHalf < 0 || v0 + kHalf >= left.rows || u0 - kHalf < 0 || u0 + kHalf >= left.cols ||
      xi - kHalf < 0 || xi + kHalf + 1 >= right.cols)
    return -1.0;
  double sl = 0.0, sr = 0.0, sll = 0.0, srr = 0.0, slr = 0.0;
  for (int dy = -kHalf; dy <= kHalf; ++dy) {
    const uint8_t* lp = left.ptr<uint8_t>(v0 + dy) + u0 - kHalf;
    const uint8_t* rp = right.ptr<uint8_t>(v0 + dy) + xi - kHalf;
    for (int dx = 0; dx < n; ++dx) {
      const double l = lp[dx], r = (1.0 - a) * rp[dx] + a * rp[dx + 1];
      sl += l;
      sr += r;
      sll += l * l;
      srr += r * r;
      slr += l * r;
    }
  }
  const double m = n * n;
  const double vl = sll - sl * sl / m, vr = srr - sr * sr / m;
  if (!(vl > 1e-9 && vr > 1e-9)) return -1.0;
  return (slr - sl * sr / m) / std::sqrt(vl * vr);
}

}  // namespace

namespace {

/// Best and second-best distances of one query over its candidates (for the ratio test),
/// and each candidate's own best query (for the mutual-best check). The ratio test asks
/// whether another place looks as alike as the best: a candidate within `same_place` pixels
/// of the best one is the same corner detected again (at another pyramid level, or at a
/// neighbouring pixel) and is no rival. A sharp corner looks alike at every scale, so in an
/// image with few corners each one is often found two to four times, and counting those copies
/// as rivals can refuse every match of it (same_corner_radius; 0 counts them).
struct CandidateSearch {
  int best = INT_MAX, second = INT_MAX, best_index = -1;
  /// (candidate, distance) of every offer: kept only when copies are told apart (`same_place`
  /// > 0), since then the rival is known only once the best is.
  std::vector<std::pair<int, int>> offered;
  const double same_place;
  const bool keep_offers;

  explicit CandidateSearch(double same_place_px)
      : same_place(same_place_px), keep_offers(same_place_px > 0.0) {}

  /// Offers candidate j at Hamming distance `dist` to query i.
  void Offer(int i, int j, int dist, std::vector<int>* best_dist_of_candidate,
             std::vector<int>* best_query_of_candidate) {
    if (dist < best) {
      second = best;
      best = dist;
      best_index = j;
    } else if (dist < second) {
      second = dist;
    }
    if (keep_offers) offered.emplace_back(j, dist);
    if (dist < (*best_dist_of_candidate)[j]) {
      (*best_dist_of_candidate)[j] = dist;
      (*best_query_of_candidate)[j] = i;
    }
  }

  /// True when the best candidate is close enough and clearly better than the best rival:
  /// the second best, or with `same_place` > 0 the best of the candidates farther than
  /// `same_place` pixels from it (`uv(j)`).
  template <typename Position>
  bool Passes(int max_distance, double ratio, const Position& uv) const {
    if (best_index < 0 || best > max_distance) return false;
    int rival = second;
    if (keep_offers) {
      const Eigen::Vector2d at = uv(best_index);
      rival = INT_MAX;
      for (const auto& [j, dist] : offered)
        if (j != best_index && dist < rival && (uv(j) - at).norm() > same_place) rival = dist;
    }
    return rival == INT_MAX || best < ratio * rival;
  }
};

}  // namespace

int MatchStereoPoints(const StereoCamera& camera, const cv::Mat& left_image,
                      const cv::Mat& right_image, const std::vector<cv::KeyPoint>& left_kp,
                      const cv::Mat& left_desc, const std::vector<cv::KeyPoint>& right_kp,
                      const cv::Mat& right_desc, const PointMatchingOptions& options,
                      PointFeatures* points) {
  points->assign(left_kp.size(), PointFeature());
  for (size_t i = 0; i < left_kp.size(); ++i) {
    (*points)[i].uv = Eigen::Vector2d(left_kp[i].pt.x, left_kp[i].pt.y);
    (*points)[i].octave = left_kp[i].octave;
  }
  if (left_kp.empty()) return 0;
  const bool descriptors = !right_kp.empty() && !left_desc.empty() && !right_desc.empty();
  const int rows = std::max(1, right_image.rows > 0 ? right_image.rows : camera.height);

  // Right keypoints by image row: a left keypoint only looks at its epipolar band.
  std::vector<std::vector<int>> by_row(rows);
  for (int j = 0; j < static_cast<int>(right_kp.size()); ++j) {
    const int v = std::clamp(static_cast<int>(std::lround(right_kp[j].pt.y)), 0, rows - 1);
    by_row[v].push_back(j);
  }
  std::vector<int> match_of_left(left_kp.size(), -1);
  std::vector<int> best_left_of_right(right_kp.size(), -1),
      best_dist_of_right(right_kp.size(), INT_MAX);
  for (int i = 0; descriptors && i < static_cast<int>(left_kp.size()); ++i) {
    const cv::KeyPoint& kl = left_kp[i];
    const double tol = options.stereo_row_tolerance * std::pow(1.2, kl.octave);
    const int r0 = std::max(0, static_cast<int>(std::floor(kl.pt.y - tol)));
    const int r1 = std::min(rows - 1, static_cast<int>(std::ceil(kl.pt.y + tol)));
    const uint8_t* dl = left_desc.ptr<uint8_t>(i);
    CandidateSearch search(options.same_corner_radius);
    for (int r = r0; r <= r1; ++r) {
      for (int j : by_row[r]) {
        const cv::KeyPoint& kr = right_kp[j];
        const double d = camera.TrueDisparity(kl.pt.x - kr.pt.x);
        if (d < options.min_disparity || d > options.max_disparity) continue;
        if (std::abs(kl.octave - kr.octave) > 1) continue;
        search.Offer(i, j, HammingDistance32(dl, right_desc.ptr<uint8_t>(j)), &best_dist_of_right,
                     &best_left_of_right);
      }
    }
    if (!search.Passes(options.max_distance, options.stereo_ratio,
                       [&](int j) { return Eigen::Vector2d(right_kp[j].pt.x, right_kp[j].pt.y); }))
      continue;
    match_of_left[i] = search.best_index;
  }
  const bool images = !left_image.empty() && !right_image.empty() && left_image.type() == CV_8UC1 &&
                      right_image.type() == CV_8UC1 && left_image.size() == right_image.size();
  int descriptor_matches = 0;
  for (int i = 0; i < static_cast<int>(left_kp.size()); ++i)
    descriptor_matches += match_of_left[i] >= 0 && best_left_of_right[match_of_left[i]] == i;
  const bool row_search =
      images && options.row_search_min_zncc > 0.0 && descriptor_matches < options.row_search_below;
  match_internal::RightSums sums;
  int matched = 0;
  for (int i = 0; i < static_cast<int>(left_kp.size()); ++i) {
    int j = match_of_left[i];
    if (j >= 0 && best_left_of_right[j] != i) j = -1;  // mutual best only
    PointFeature& pf = (*points)[i];
    double ur = 0.0;
    if (j >= 0) {
      ur = right_kp[j].pt.x;
      if (options.subpixel && images)
        RefineDisparity(left_image, right_image, pf.uv.x(), pf.uv.y(), &ur);
    } else {
      // No right keypoint: the row itself, over the disparity range (measured disparity =
      // true - doffs).
      if (!row_search) continue;
      const int u0 = static_cast<int>(std::lround(pf.uv.x()));
      const int c0 =
          static_cast<int>(std::floor(pf.uv.x() - (options.max_disparity - camera.doffs)));
      const int c1 =
          static_cast<int>(std::ceil(pf.uv.x() - (options.min_disparity - camera.doffs)));
      const int v0 = static_cast<int>(std::lround(pf.uv.y()));
      if (!match_internal::SearchRow(left_image, right_image, &sums, u0, v0, c0, c1,
                                     options.row_search_min_zncc, options.row_search_margin, &ur))
        continue;
      // The correlation peak is already placed to a fraction of a pixel: only the intensity
      // fit refines it (RefineDisparity's SAD search around it drifts 1-2 px on faint corners).
      if (options.subpixel)
        RefineColumnLucasKanade(left_image, right_image, u0, v0, kStereoPatchHalf, &ur);
      ur += pf.uv.x() - u0;  // the patch was centred on the rounded column
    }
    if (images && options.stereo_min_zncc > 0.0) {
      // The patches compared at the rounded left column, the right one shifted by the same
      // offset as the refined column.
      const int u0 = static_cast<int>(std::lround(pf.uv.x())),
                v0 = static_cast<int>(std::lround(pf.uv.y()));
      if (StereoPatchZncc(left_image, right_image, u0, v0, ur - (pf.uv.x() - u0)) <
          options.stereo_min_zncc)
        continue;
    }
    const double d = pf.uv.x() - ur;
    const double d_true = camera.TrueDisparity(d);
    if (d_true < options.min_disparity || d_true > options.max_disparity) continue;
    pf.has_depth = true;
    pf.disparity = d;
    pf.p_c = camera.BackProject(pf.uv.x(), pf.uv.y(), d);
    ++matched;
  }
  return matched;
}

std::vector<std::pair<int, int>> MatchPointsFrameToFrame(
    const StereoCamera& camera, const PointFeatures& prev, const cv::Mat& prev_desc,
    const PointFeatures& cur, const cv::Mat& cur_desc, const PointMatchingOptions& options,
    const SE3* T_cur_prev) {
  std::vector<std::pair<int, int>> out;
  if (prev.empty() || cur.empty() || prev_desc.empty() || cur_desc.empty()) return out;

  // Grid index of the current points for the guided search.
  constexpr int kCell = 32;
  const int gw = std::max(1, (camera.width + kCell - 1) / kCell),
            gh = std::max(1, (camera.height + kCell - 1) / kCell);
  std::vector<std::vector<int>> grid;
  if (T_cur_prev) {
    grid.resize(static_cast<size_t>(gw) * gh);
    for (int j = 0; j < static_cast<int>(cur.size()); ++j) {
      const int cx = std::clamp(static_cast<int>(cur[j].uv.x()) / kCell, 0, gw - 1);
      const int cy = std::clamp(static_cast<int>(cur[j].uv.y()) / kCell, 0, gh - 1);
      grid[cy * gw + cx].push_back(j);
    }
  }
  std::vector<int> match_of_prev(prev.size(), -1);
  std::vector<int> best_prev_of_cur(cur.size(), -1), best_dist_of_cur(cur.size(), INT_MAX);
  const double r2 = options.search_radius * options.search_radius;
  for (int i = 0; i < static_cast<int>(prev.size()); ++i) {
    if (!prev[i].has_depth) continue;
    const uint8_t* dp = prev_desc.ptr<uint8_t>(i);
    CandidateSearch search(options.same_corner_radius);
    auto consider = [&](int j) {
      if (std::abs(prev[i].octave - cur[j].octave) > 2) return;
      search.Offer(i, j, HammingDistance32(dp, cur_desc.ptr<uint8_t>(j)), &best_dist_of_cur,
                   &best_prev_of_cur);
    };
    if (T_cur_prev) {
      const Eigen::Vector3d p = (*T_cur_prev) * prev[i].p_c;
      if (p.z() <= 0.05) continue;
      const Eigen::Vector2d uv = camera.Project(p);
      const int x0 = std::max(0, static_cast<int>((uv.x() - options.search_radius) / kCell));
      const int x1 = std::min(gw - 1, static_cast<int>((uv.x() + options.search_radius) / kCell));
      const int y0 = std::max(0, static_cast<int>((uv.y() - options.search_radius) / kCell));
      const int y1 = std::min(gh - 1, static_cast<int>((uv.y() + options.search_radius) / kCell));
      for (int gy = y0; gy <= y1; ++gy)
        for (int gx = x0; gx <= x1; ++gx)
          for (int j : grid[gy * gw + gx])
            if ((cur[j].uv - uv).squaredNorm() <= r2) consider(j);
    } else {
      for (int j = 0; j < static_cast<int>(cur.size()); ++j) consider(j);
    }
    if (!search.Passes(options.max_distance, options.f2f_ratio, [&](int j) { return cur[j].uv; }))
      continue;
    match_of_prev[i] = search.best_index;
  }
  for (int i = 0; i < static_cast<int>(prev.size()); ++i) {
    const int j = match_of_prev[i];
    if (j >= 0 && best_prev_of_cur[j] == i) out.emplace_back(i, j);
  }
  return out;
}

std::vector<std::pair<int, int>> MatchPointsPredicted(
    const StereoCamera& camera, const PointFeatures& prev, const cv::Mat& prev_desc,
    const PointFeatures& cur, const cv::Mat& cur_desc, const PointMatchingOptions& options,
    const SE3& T_cur_prev, int everywhere_below) {
  auto matches =
      MatchPointsFrameToFrame(camera, prev, prev_desc, cur, cur_desc, options, &T_cur_prev);
  if (static_cast<int>(matches.size()) < everywhere_below) {
    auto everywhere = MatchPointsFrameToFrame(camera, prev, prev_desc, cur, cur_desc, options);
    if (everywhere.size() > matches.size()) matches = std::move(everywhere);
  }
  return matches;
}

}  // namespace pl_slam
