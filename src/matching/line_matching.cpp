#include "pl_slam/matching/line_matching.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include <Eigen/StdVector>

#include "pl_slam/util/error.h"
#include "row_search.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

using Points2d = std::vector<Eigen::Vector2d, Eigen::aligned_allocator<Eigen::Vector2d>>;

double Deg2Rad(double deg) { return deg * kPi / 180.0; }

// Absolute difference of two directions, in [0, pi].
double AngleDiff(double a, double b) {
  double d = std::fmod(std::abs(a - b), 2.0 * kPi);
  return d > kPi ? 2.0 * kPi - d : d;
}

double LengthRatio(double a, double b) {
  const double hi = std::max(a, b);
  return hi > 0.0 ? std::min(a, b) / hi : 0.0;
}

void CheckDescriptors(const char* what, const cv::Mat& desc, size_t n) {
  if (n == 0) return;
  if (desc.type() != CV_8UC1 || desc.cols != 32 || desc.rows != static_cast<int>(n)) {
    std::ostringstream os;
    os << what << ": descriptors must be CV_8UC1 with 32 columns and one row per line (" << n
       << " lines, got " << desc.rows << "x" << desc.cols << " type " << desc.type() << ")";
    throw InputError(os.str());
  }
}

// Best and second-best candidate of one query, and the mutual-best bookkeeping.
struct Best {
  int index = -1;
  int distance = INT_MAX;
  int second = INT_MAX;
  void Offer(int j, int d) {
    if (d < distance) {
      second = distance;
      distance = d;
      index = j;
    } else if (d < second) {
      second = d;
    }
  }
  // Ratio test: the best must be clearly better than the runner-up; a lone candidate passes.
  bool Passes(double ratio, int max_distance) const {
    if (index < 0 || distance > max_distance) return false;
    return second == INT_MAX || distance < ratio * second;
  }
};

// Resolves mutual best matches from per-query and per-train bests.
std::vector<std::pair<int, int>> MutualMatches(const std::vector<Best>& query_best,
                                               const std::vector<Best>& train_best, double ratio,
                                               int max_distance) {
  std::vector<std::pair<int, int>> matches;
  for (int i = 0; i < static_cast<int>(query_best.size()); ++i) {
    const Best& b = query_best[i];
    if (!b.Passes(ratio, max_distance)) continue;
    if (train_best[b.index].index != i) continue;
    matches.emplace_back(i, b.index);
  }
  return matches;
}

// Where the normalised infinite line `l` crosses row v (|l(0)| must be clearly non-zero).
inline double ColumnAtRow(const Eigen::Vector3d& l, double v) { return -(l(1) * v + l(2)) / l(0); }

// The disparity at endpoint `end` of a flat segment `f`, from a segment with depth that ends
// where `f` ends (an L junction: a frame's corner, a lintel on its jamb). Both segments must
// cross at kMinJunctionAngleDeg or more, and their crossing lie within `radius` of `end` and of
// an endpoint of the other segment; a segment that runs on past the crossing may be an
// occluding edge in front of `f`, so a T junction gives no depth. Segments marked `flat` never
// lend their depth. False when no segment or two that disagree by more than a pixel qualify.
bool DisparityAtJunction(const LineFeatures& lines, const std::vector<char>& flat,
                         const Points2d& disparities, const LineFeature& f,
                         const Eigen::Vector2d& end, double radius, double* disparity) {
  constexpr double kMinJunctionAngleDeg = 30.0;
  const double min_sin = std::sin(Deg2Rad(kMinJunctionAngleDeg));
  double best_gap = radius * 2.0 + 1.0;
  bool found = false;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    const LineFeature& m = lines[k];
    // Depth from the row crossing only (flat segments get theirs in this pass).
    if (!m.has_depth || flat[k]) continue;
    if (std::abs(std::sin(f.angle - m.angle)) < min_sin) continue;
    const Eigen::Vector3d x = f.l.cross(m.l);
    if (std::abs(x.z()) < 1e-12) continue;
    const Eigen::Vector2d X = x.head<2>() / x.z();
    const double to_end = (X - end).norm();
    const double to_m = std::min((X - m.s).norm(), (X - m.e).norm());
    // Written so that a degenerate segment (NaN line) never qualifies.
    if (!(to_end <= radius && to_m <= radius && m.length > 0.0)) continue;
    const double t = std::clamp((X - m.s).dot(m.e - m.s) / (m.length * m.length), 0.0, 1.0);
    const double d = disparities[k].x() + t * (disparities[k].y() - disparities[k].x());
    if (found && std::abs(d - *disparity) > 1.0) return false;
    if (to_end + to_m < best_gap) {
      best_gap = to_end + to_m;
      *disparity = d;
    }
    found = true;
  }
  return found;
}

// The right segment among `right` not yet taken that best matches left segment `f` (its
// descriptor `dl` within max_distance, direction within stereo_max_angle_deg) with its start
// within `radius` of `s_right` and its end within `radius` of `e_right`; -1 when none. A
// negative radius skips that end's test.
int RightAtEnds(const LineFeature& f, const uint8_t* dl, const LineFeatures& right,
                const cv::Mat& right_desc, const LineMatchingOptions& options,
                const std::vector<char>& right_taken, const Eigen::Vector2d& s_right,
                double s_radius, const Eigen::Vector2d& e_right, double e_radius) {
  const double max_angle = Deg2Rad(options.stereo_max_angle_deg);
  int best = -1, best_distance = options.max_distance + 1;
  for (std::size_t j = 0; j < right.size(); ++j) {
    const LineFeature& r = right[j];
    if (right_taken[j] || AngleDiff(f.angle, r.angle) > max_angle) continue;
    if (s_radius >= 0.0 && !((r.s - s_right).norm() <= s_radius)) continue;
    if (e_radius >= 0.0 && !((r.e - e_right).norm() <= e_radius)) continue;
    const int d = LineDescriptorDistance(dl, right_desc.ptr<uint8_t>(static_cast<int>(j)));
    if (d < best_distance) {
      best_distance = d;
      best = static_cast<int>(j);
    }
  }
  return best;
}

// Depth for flat segments (`flat`: too close to the rows for the row crossing), which the
// epipolar geometry cannot give: where both ends are L junctions with segments that have
// depth, the endpoints take those segments' disparities there. Kept only when the right image
// shows a segment of the same direction between the same junctions (both endpoints within
// junction_max_px of where the disparities put them, a descriptor within max_distance) that no
// other left segment took. With junction_one_end (and the images), a segment with one such
// end whose right segment starts at that junction takes, at its free end, the disparity of the
// end's own patch, searched on its row near the right segment's end (a flat edge's end is a
// corner both images see, unless the image border cuts it: then nothing). Returns the number
// of segments given depth.
int JunctionDepth(const StereoCamera& camera, LineFeatures* left, const cv::Mat& left_desc,
                  const LineFeatures& right, const cv::Mat& right_desc,
                  const LineMatchingOptions& options, const std::vector<char>& flat,
                  const Points2d& disparities, const cv::Mat& left_image,
                  const cv::Mat& right_image, std::vector<char>* right_taken,
                  std::vector<int>* right_of_left) {
  // Free ends: the patch around the left end must correlate (ZNCC) at least this well on its
  // row near the right segment's end, with a peak this far above every other column there.
  constexpr double kFreeEndMinZncc = 0.8, kFreeEndMargin = 0.1;
  // A flat segment of a level camera's view of a building is nearly always an edge parallel to
  // the baseline (a lintel, a shelf, a board's top), whose depth hardly changes along it; the
  // free end's patch found at a disparity this far (relative) from the junction's is more often
  // the right image's next corner along the edge.
  constexpr double kFreeEndMaxChange = 0.1;
  const bool images = !left_image.empty() && !right_image.empty();
  match_internal::RightSums sums;
  const double radius = options.junction_max_px;
  // A free end this close to the border may be where the image cuts the edge.
  const double border = 2.0 * radius + 2.0;
  LineFeatures& lines = *left;
  int added = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    LineFeature& f = lines[i];
    if (!flat[i] || f.has_depth) continue;
    double d_s = 0.0, d_e = 0.0;
    const bool at_s = DisparityAtJunction(lines, flat, disparities, f, f.s, radius, &d_s);
    const bool at_e = DisparityAtJunction(lines, flat, disparities, f, f.e, radius, &d_e);
    if (!at_s && !at_e) continue;
    const bool one = !(at_s && at_e);
    if (one && !(options.junction_one_end && images)) continue;
    if (one && !camera.InImage(at_s ? f.e : f.s, border)) continue;
    const uint8_t* dl = left_desc.ptr<uint8_t>(static_cast<int>(i));
    const Eigen::Vector2d s_right(f.s.x() - d_s, f.s.y()), e_right(f.e.x() - d_e, f.e.y());
    // A free end's right partner lies on the same row (rectified), anywhere along it.
    const int best = RightAtEnds(f, dl, right, right_desc, options, *right_taken, s_right,
                                 at_s ? radius : -1.0, e_right, at_e ? radius : -1.0);
    if (best < 0) continue;
    if (one) {
      const Eigen::Vector2d& free = at_s ? f.e : f.s;
      const Eigen::Vector2d& free_right = at_s ? right[best].e : right[best].s;
      if (!(camera.InImage(free_right, border) && std::abs(free_right.y() - free.y()) <= radius))
        continue;
      // Where the detector ends a segment is no place both images agree on (a weak stretch
      // cuts one of them short): the end's own patch, found on its row near the right end,
      // gives the disparity, and an edge that runs on through the patch (no peak) gives none.
      const int u0 = static_cast<int>(std::lround(free.x()));
      const int v0 = static_cast<int>(std::lround(free.y()));
      const double guess = free_right.x() - (free.x() - u0);
      const int reach = static_cast<int>(std::ceil(radius)) + 2;
      double ur = 0.0;
      if (!match_internal::SearchRow(
              left_image, right_image, &sums, u0, v0, static_cast<int>(std::floor(guess)) - reach,
              static_cast<int>(std::ceil(guess)) + reach, kFreeEndMinZncc, kFreeEndMargin, &ur))
        continue;
      const double d_junction = at_s ? d_s : d_e, d_free = u0 - ur;
      if (!(std::abs(d_free - d_junction) <= kFreeEndMaxChange * camera.TrueDisparity(d_junction)))
        continue;
      (at_s ? d_e : d_s) = d_free;
    }
    const double t_s = camera.TrueDisparity(d_s), t_e = camera.TrueDisparity(d_e);
    if (!(t_s >= options.min_disparity && t_e >= options.min_disparity)) continue;
    if (!(t_s <= options.max_disparity && t_e <= options.max_disparity)) continue;
    if (!(std::abs(d_s - d_e) <= options.max_disparity_gradient * f.length)) continue;
    f.P_c = camera.BackProject(f.s.x(), f.s.y(), d_s);
    f.Q_c = camera.BackProject(f.e.x(), f.e.y(), d_e);
    f.has_depth = true;
    f.depth_from_junctions = true;
    f.one_junction = one;
    (*right_taken)[best] = 1;
    if (right_of_left) (*right_of_left)[i] = best;
    ++added;
  }
  return added;
}

}  // namespace

std::string LineMatchingOptions::Validate() const {
  std::ostringstream os;
  auto in = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
  if (max_distance < 0 || max_distance > 256) {
    os << "max_distance=" << max_distance << " must be in [0, 256]";
  } else if (!(stereo_ratio > 0.0 && stereo_ratio <= 1.0)) {
    os << "stereo_ratio=" << stereo_ratio << " must be in (0, 1]";
  } else if (!in(stereo_max_angle_deg, 0.0, 90.0)) {
    os << "stereo_max_angle_deg=" << stereo_max_angle_deg << " must be in [0, 90]";
  } else if (!in(stereo_min_length_ratio, 0.0, 1.0)) {
    os << "stereo_min_length_ratio=" << stereo_min_length_ratio << " must be in [0, 1]";
  } else if (!in(stereo_min_row_overlap, 0.0, 1.0)) {
    os << "stereo_min_row_overlap=" << stereo_min_row_overlap << " must be in [0, 1]";
  } else if (!(min_disparity > 0.0 && min_disparity <= 1000.0)) {
    os << "min_disparity=" << min_disparity << " must be in (0, 1000]";
  } else if (!(max_disparity >= min_disparity && max_disparity <= 5000.0)) {
    os << "max_disparity=" << max_disparity << " must be in [min_disparity, 5000]";
  } else if (!in(max_disparity_gradient, 0.0, 10.0)) {
    os << "max_disparity_gradient=" << max_disparity_gradient << " must be in [0, 10]";
  } else if (!in(min_stereo_angle_deg, 1.0, 89.0)) {
    os << "min_stereo_angle_deg=" << min_stereo_angle_deg << " must be in [1, 89]";
  } else if (!(f2f_ratio > 0.0 && f2f_ratio <= 1.0)) {
    os << "f2f_ratio=" << f2f_ratio << " must be in (0, 1]";
  } else if (!in(f2f_max_angle_deg, 0.0, 180.0)) {
    os << "f2f_max_angle_deg=" << f2f_max_angle_deg << " must be in [0, 180]";
  } else if (!in(f2f_min_length_ratio, 0.0, 1.0)) {
    os << "f2f_min_length_ratio=" << f2f_min_length_ratio << " must be in [0, 1]";
  } else if (!(f2f_max_line_distance > 0.0 && f2f_max_line_distance <= 1000.0)) {
    os << "f2f_max_line_distance=" << f2f_max_line_distance << " must be in (0, 1000]";
  } else if (!in(f2f_max_gap, 0.0, 1000.0)) {
    os << "f2f_max_gap=" << f2f_max_gap << " must be in [0, 1000]";
  } else if (!in(junction_max_px, 0.0, 20.0)) {
    os << "junction_max_px=" << junction_max_px << " must be in [0, 20]";
  }
  return os.str();
}

int LineDescriptorDistance(const uint8_t* a, const uint8_t* b) {
  int d = 0;
  for (int k = 0; k < 4; ++k) {
    uint64_t x, y;
    std::memcpy(&x, a + 8 * k, 8);
    std::memcpy(&y, b + 8 * k, 8);
    d += __builtin_popcountll(x ^ y);
  }
  return d;
}

int MatchStereoLines(const StereoCamera& camera, LineFeatures* left, const cv::Mat& left_desc,
                     const LineFeatures& right, const cv::Mat& right_desc,
                     const LineMatchingOptions& options, std::vector<int>* right_of_left,
                     const cv::Mat& left_image, const cv::Mat& right_image) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("line_matching." + err);
  CheckDescriptors("MatchStereoLines left", left_desc, left->size());
  CheckDescriptors("MatchStereoLines right", right_desc, right.size());
  const int nl = static_cast<int>(left->size());
  const int nr = static_cast<int>(right.size());
  for (LineFeature& f : *left) {
    f.has_depth = false;
    f.depth_from_junctions = false;
    f.one_junction = false;
    f.P_c.setZero();
    f.Q_c.setZero();
  }
  if (right_of_left) right_of_left->assign(nl, -1);
  if (nl == 0 || nr == 0) return 0;

  // |sin| of the angle to the rows: below the threshold the row crossing is ill-conditioned
  // (a row error of 1 px moves it by 1/|sin| px along the row).
  const double min_sin = std::sin(Deg2Rad(options.min_stereo_angle_deg));
  const double max_angle = Deg2Rad(options.stereo_max_angle_deg);
  auto steep = [min_sin](const LineFeature& f) { return std::abs(std::sin(f.angle)) >= min_sin; };
  std::vector<char> right_ok(nr);
  for (int j = 0; j < nr; ++j) right_ok[j] = steep(right[j]);

  // Disparities of the best candidate of each left line, kept for triangulation.
  std::vector<Best> left_best(nl), right_best(nr);
  Points2d best_disp(nl);
  for (int i = 0; i < nl; ++i) {
    const LineFeature& l = (*left)[i];
    if (!steep(l)) continue;
    const double l_lo = std::min(l.s.y(), l.e.y()), l_hi = std::max(l.s.y(), l.e.y());
    const uint8_t* dl = left_desc.ptr<uint8_t>(i);
    for (int j = 0; j < nr; ++j) {
      if (!right_ok[j]) continue;
      const LineFeature& r = right[j];
      if (AngleDiff(l.angle, r.angle) > max_angle) continue;
      if (LengthRatio(l.length, r.length) < options.stereo_min_length_ratio) continue;
      // Epipolar constraint of segments: they must share most of their rows.
      const double r_lo = std::min(r.s.y(), r.e.y()), r_hi = std::max(r.s.y(), r.e.y());
      const double shared = std::min(l_hi, r_hi) - std::max(l_lo, r_lo);
      if (shared < options.stereo_min_row_overlap * std::max(l_hi - l_lo, r_hi - r_lo)) continue;
      const double d_s = l.s.x() - ColumnAtRow(r.l, l.s.y());
      const double d_e = l.e.x() - ColumnAtRow(r.l, l.e.y());
      const double t_s = camera.TrueDisparity(d_s), t_e = camera.TrueDisparity(d_e);
      if (t_s < options.min_disparity || t_e < options.min_disparity) continue;
      if (t_s > options.max_disparity || t_e > options.max_disparity) continue;
      // Disparity is linear along the image of a 3D segment; a steep change along it means
      // a segment running almost along the viewing rays, which is far more often a wrong
      // pairing than a real structure.
      if (std::abs(d_s - d_e) > options.max_disparity_gradient * l.length) continue;
      const int d = LineDescriptorDistance(dl, right_desc.ptr<uint8_t>(j));
      const int before = left_best[i].index;
      left_best[i].Offer(j, d);
      if (left_best[i].index != before) best_disp[i] = {d_s, d_e};
      right_best[j].Offer(i, d);
    }
  }

  int matched = 0;
  std::vector<char> right_taken(nr, 0);
  for (const auto& [i, j] :
       MutualMatches(left_best, right_best, options.stereo_ratio, options.max_distance)) {
    LineFeature& l = (*left)[i];
    l.P_c = camera.BackProject(l.s.x(), l.s.y(), best_disp[i].x());
    l.Q_c = camera.BackProject(l.e.x(), l.e.y(), best_disp[i].y());
    l.has_depth = true;
    right_taken[j] = 1;
    if (right_of_left) (*right_of_left)[i] = j;
    ++matched;
  }
  if (options.junction_max_px > 0.0) {
    std::vector<char> flat(nl);
    for (int i = 0; i < nl; ++i) flat[i] = !steep((*left)[i]);
    matched += JunctionDepth(camera, left, left_desc, right, right_desc, options, flat, best_disp,
                             left_image, right_image, &right_taken, right_of_left);
  }
  return matched;
}

std::vector<std::pair<int, int>> MatchLines(const LineFeatures& prev, const cv::Mat& prev_desc,
                                            const LineFeatures& cur, const cv::Mat& cur_desc,
                                            const LineMatchingOptions& options,
                                            const LinePrediction* prediction) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("line_matching." + err);
  CheckDescriptors("MatchLines prev", prev_desc, prev.size());
  CheckDescriptors("MatchLines cur", cur_desc, cur.size());
  const int np = static_cast<int>(prev.size());
  const int nc = static_cast<int>(cur.size());
  if (np == 0 || nc == 0) return {};
  const double max_angle = Deg2Rad(options.f2f_max_angle_deg);

  // Predicted image segments of previous lines with depth (both endpoints in front).
  std::vector<char> guided(np, 0);
  Points2d pred_s(np), pred_e(np);
  std::vector<double> pred_angle(np, 0.0), pred_length(np, 0.0);
  if (prediction) {
    constexpr double kMinDepth = 1e-3;  // metres; closer is behind or on the camera plane
    for (int i = 0; i < np; ++i) {
      const LineFeature& p = prev[i];
      if (!p.has_depth) continue;
      const Eigen::Vector3d P = prediction->T_cur_prev * p.P_c;
      const Eigen::Vector3d Q = prediction->T_cur_prev * p.Q_c;
      if (P.z() < kMinDepth || Q.z() < kMinDepth) continue;
      pred_s[i] = prediction->camera.Project(P);
      pred_e[i] = prediction->camera.Project(Q);
      const Eigen::Vector2d d = pred_e[i] - pred_s[i];
      pred_length[i] = d.norm();
      if (pred_length[i] < 1e-6) continue;
      pred_angle[i] = std::atan2(d.y(), d.x());
      guided[i] = 1;
    }
  }

  // Candidates: with a usable prediction, the current segments near the predicted one;
  // otherwise every current segment, so that the ratio test measures how distinctive the
  // descriptor is in the whole image (a gate on direction alone leaves so few candidates
  // that unrelated lines would pass it), and direction and length are checked afterwards.
  std::vector<Best> prev_best(np), cur_best(nc);
  for (int i = 0; i < np; ++i) {
    const LineFeature& p = prev[i];
    const uint8_t* dp = prev_desc.ptr<uint8_t>(i);
    for (int j = 0; j < nc; ++j) {
      const LineFeature& c = cur[j];
      if (guided[i]) {
        if (AngleDiff(pred_angle[i], c.angle) > max_angle) continue;
        if (LengthRatio(pred_length[i], c.length) < options.f2f_min_length_ratio) continue;
        const Eigen::Vector3d& l = c.l;
        const double ds = l.x() * pred_s[i].x() + l.y() * pred_s[i].y() + l.z();
        const double de = l.x() * pred_e[i].x() + l.y() * pred_e[i].y() + l.z();
        if (std::abs(ds) > options.f2f_max_line_distance ||
            std::abs(de) > options.f2f_max_line_distance)
          continue;
        // Overlap along the current segment: occlusion and fragmentation may shorten either
        // segment, but a predicted segment far beyond the observed one is another line.
        const Eigen::Vector2d u = (c.e - c.s) / c.length;
        const double t1 = u.dot(pred_s[i] - c.s), t2 = u.dot(pred_e[i] - c.s);
        const double gap = std::max(std::min(t1, t2) - c.length, -std::max(t1, t2));
        if (gap > options.f2f_max_gap) continue;
      }
      const int d = LineDescriptorDistance(dp, cur_desc.ptr<uint8_t>(j));
      prev_best[i].Offer(j, d);
      cur_best[j].Offer(i, d);
    }
    // Unguided: the best must also agree in direction and length (the paper's filter).
    Best& b = prev_best[i];
    if (!guided[i] && b.index >= 0) {
      const LineFeature& c = cur[b.index];
      if (AngleDiff(p.angle, c.angle) > max_angle ||
          LengthRatio(p.length, c.length) < options.f2f_min_length_ratio) {
        b.index = -1;
      }
    }
  }
  return MutualMatches(prev_best, cur_best, options.f2f_ratio, options.max_distance);
}

std::vector<std::pair<int, int>> MatchLinesPredicted(
    const LineFeatures& prev, const cv::Mat& prev_desc, const LineFeatures& cur,
    const cv::Mat& cur_desc, const LineMatchingOptions& options, const LinePrediction& prediction,
    int everywhere_below) {
  auto matches = MatchLines(prev, prev_desc, cur, cur_desc, options, &prediction);
  if (static_cast<int>(matches.size()) < everywhere_below) {
    auto everywhere = MatchLines(prev, prev_desc, cur, cur_desc, options);
    if (everywhere.size() > matches.size()) matches = std::move(everywhere);
  }
  return matches;
}

}  // namespace pl_slam
