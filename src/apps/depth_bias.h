// Scoring of pl_slam_bench_depth (header-only so that its test can use it without the tool):
// signed disparity errors of stereo features against ground truth, binned by true depth, and
// the ground-truth disparity of a segment's endpoints from samples along it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace pl_slam::bench {

/// Depth bins [edges[i], edges[i+1]) in metres; the last bin is open (edges.back() and more).
struct DepthBins {
  std::vector<double> edges = {0.0, 5.0, 10.0, 20.0, 40.0, 80.0};

  int size() const { return static_cast<int>(edges.size()); }
  /// Bin of depth z (metres), -1 for z < edges.front() or a non-finite z.
  int Index(double z) const {
    if (!std::isfinite(z) || z < edges.front()) return -1;
    const int i = static_cast<int>(std::upper_bound(edges.begin(), edges.end(), z) - edges.begin());
    return i - 1;
  }
  /// "0-5", ..., "80+".
  std::string Label(int i) const {
    char buf[48];
    if (i + 1 < size()) {
      std::snprintf(buf, sizeof(buf), "%g-%g", edges[i], edges[i + 1]);
    } else {
      std::snprintf(buf, sizeof(buf), "%g+", edges[i]);
    }
    return buf;
  }
};

/// One scored feature: measured and true disparity (both geometric, doffs applied) and the
/// true depth.
struct DisparitySample {
  double d_meas = 0.0;      ///< measured disparity, px
  double d_gt = 0.0;        ///< ground-truth disparity at the feature, px
  double z_gt = 0.0;        ///< ground-truth depth, metres (what the sample is binned by)
  double u = 0.0, v = 0.0;  ///< where it was measured (left image), for reference matchers
};

/// Statistics of the signed errors e = d_meas - d_gt of one bin.
struct BiasStats {
  int count = 0;
  double mean = NAN;         ///< mean error (the bias, including gross errors), px
  double core_mean = NAN;    ///< mean of the errors within 1 px of the median, px
  double median = NAN;       ///< median error, px
  double median_se = NAN;    ///< standard error of the median (1.2533 * robust sigma / sqrt n)
  double sigma = NAN;        ///< robust spread: 1.4826 * median |e - median|, px
  double gross_pct = NAN;    ///< share of errors more than 1 px from the median, %
  double d_gt_median = NAN;  ///< median true disparity, px
  double depth_pct = NAN;    ///< median relative depth error (Z_meas - Z_gt) / Z_gt, %
};

inline double MedianOf(std::vector<double> v) {
  if (v.empty()) return NAN;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + h, v.end());
  if (v.size() % 2) return v[h];
  const double hi = v[h];
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + h));
}

/// Statistics of a set of samples (any depth).
inline BiasStats Summarize(const std::vector<DisparitySample>& samples) {
  BiasStats s;
  s.count = static_cast<int>(samples.size());
  if (samples.empty()) return s;
  std::vector<double> e, d, rel;
  double sum = 0.0;
  for (const auto& x : samples) {
    e.push_back(x.d_meas - x.d_gt);
    d.push_back(x.d_gt);
    sum += e.back();
    // Z = fb / d, so Z_meas / Z_gt - 1 = d_gt / d_meas - 1.
    rel.push_back(x.d_meas > 0 ? 100.0 * (x.d_gt / x.d_meas - 1.0) : INFINITY);
  }
  s.mean = sum / e.size();
  s.median = MedianOf(e);
  std::vector<double> dev;
  for (double x : e) dev.push_back(std::abs(x - s.median));
  s.sigma = 1.4826 * MedianOf(dev);
  s.median_se = 1.2533 * s.sigma / std::sqrt(static_cast<double>(e.size()));
  double core = 0.0;
  int n_core = 0;
  for (double x : e) {
    if (std::abs(x - s.median) <= 1.0) {
      core += x;
      ++n_core;
    }
  }
  s.core_mean = n_core ? core / n_core : NAN;
  s.gross_pct = 100.0 * (e.size() - n_core) / e.size();
  s.d_gt_median = MedianOf(d);
  s.depth_pct = MedianOf(rel);
  return s;
}

/// Least-squares fit e = offset + scale * d_gt of the errors within 1 px of their median: an
/// offset is what a principal-point (doffs) error gives, a scale what a focal length or
/// baseline error gives. False with fewer than 10 such errors or one true disparity.
inline bool FitOffsetScale(const std::vector<DisparitySample>& samples, double* offset,
                           double* scale) {
  const double med = Summarize(samples).median;
  double n = 0, sd = 0, se = 0, sdd = 0, sde = 0;
  for (const auto& s : samples) {
    const double e = s.d_meas - s.d_gt;
    if (!(std::abs(e - med) <= 1.0)) continue;
    n += 1;
    sd += s.d_gt;
    se += e;
    sdd += s.d_gt * s.d_gt;
    sde += s.d_gt * e;
  }
  const double den = n * sdd - sd * sd;
  if (n < 10 || !(den > 1e-9 * n * n)) return false;
  *scale = (n * sde - sd * se) / den;
  *offset = (se - *scale * sd) / n;
  return true;
}

/// Samples of one feature type, binned by true depth.
class BiasTable {
 public:
  explicit BiasTable(DepthBins bins = DepthBins())
      : bins_(std::move(bins)), per_bin_(bins_.size()) {}

  /// Adds a sample; returns false (and drops it) when its depth falls in no bin.
  bool Add(const DisparitySample& s) {
    const int i = bins_.Index(s.z_gt);
    if (i < 0) return false;
    per_bin_[i].push_back(s);
    all_.push_back(s);
    return true;
  }
  const DepthBins& bins() const { return bins_; }
  const std::vector<DisparitySample>& bin(int i) const { return per_bin_[i]; }
  const std::vector<DisparitySample>& all() const { return all_; }

  /// Markdown table: one row per depth bin and one for all depths.
  std::string Markdown() const {
    std::string out =
        "| depth (m) | n | mean err (px) | mean within 1 px of median | median err (px) | "
        "robust sigma (px) | > 1 px from median | median true disparity (px) | depth bias "
        "(median, %) |\n|---|---|---|---|---|---|---|---|---|\n";
    for (int i = 0; i <= bins_.size(); ++i) {
      const bool total = i == bins_.size();
      const BiasStats s = Summarize(total ? all_ : per_bin_[i]);
      char buf[320];
      if (s.count == 0) {
        std::snprintf(buf, sizeof(buf), "| %s | 0 | | | | | | | |\n",
                      total ? "all" : bins_.Label(i).c_str());
      } else {
        std::snprintf(buf, sizeof(buf),
                      "| %s | %d | %+.3f | %+.3f | %+.3f ± %.3f | %.3f | %.1f%% | %.1f | %+.2f |\n",
                      total ? "**all**" : bins_.Label(i).c_str(), s.count, s.mean, s.core_mean,
                      s.median, s.median_se, s.sigma, s.gross_pct, s.d_gt_median, s.depth_pct);
      }
      out += buf;
    }
    double a = 0, b = 0;
    if (FitOffsetScale(all_, &a, &b)) {
      char buf[160];
      std::snprintf(buf, sizeof(buf),
                    "\nerror model (errors within 1 px of the median): %+.3f px %+.2f%% of the "
                    "true disparity\n",
                    a, 100.0 * b);
      out += buf;
    }
    return out;
  }

 private:
  DepthBins bins_;
  std::vector<std::vector<DisparitySample>> per_bin_;
  std::vector<DisparitySample> all_;
};

/// Median error by the fractional part of the true disparity, in quarters [0, .25) ... [.75, 1):
/// a refinement that pulls towards whole-pixel disparities shows negative errors in the
/// second quarter and positive ones in the third (a pull away from them, the opposite). Only
/// errors within 1 px of the overall median count (gross mismatches say nothing about it).
inline std::vector<BiasStats> ByFraction(const std::vector<DisparitySample>& samples) {
  std::vector<DisparitySample> all = samples;
  const double med = Summarize(all).median;
  std::vector<std::vector<DisparitySample>> q(4);
  for (const auto& s : samples) {
    if (!(std::abs(s.d_meas - s.d_gt - med) <= 1.0)) continue;
    const double f = s.d_gt - std::floor(s.d_gt);
    q[std::min(3, static_cast<int>(f * 4.0))].push_back(s);
  }
  std::vector<BiasStats> out;
  for (const auto& v : q) out.push_back(Summarize(v));
  return out;
}

/// True for a segment steeper than 45 degrees from the image rows (near-vertical).
inline bool IsSteep(double angle_rad) { return std::abs(std::sin(angle_rad)) > std::sqrt(0.5); }

/// Ground-truth disparity at the endpoints (t = 0 and t = 1) of a segment from samples
/// (t, d_gt) along it. Disparity is linear along the image of a 3D segment, so a line is
/// fitted by least squares; the sample farthest from it is dropped while any is more than
/// `tolerance` px off (samples on another surface: an occluder, a detector that ran past the
/// edge's end), as long as at least `min_keep` of them and 60% remain. False when they do not.
inline bool FitEndpointDisparities(std::vector<std::pair<double, double>> td, double tolerance,
                                   int min_keep, double* d0, double* d1) {
  const size_t keep = std::max<size_t>(static_cast<size_t>(min_keep),
                                       static_cast<size_t>(std::ceil(0.6 * td.size())));
  while (td.size() >= std::max<size_t>(keep, 2)) {
    double st = 0, sd = 0, stt = 0, std_ = 0;
    for (const auto& [t, d] : td) {
      st += t;
      sd += d;
      stt += t * t;
      std_ += t * d;
    }
    const double n = static_cast<double>(td.size());
    const double den = n * stt - st * st;
    if (!(std::abs(den) > 1e-12)) return false;
    const double b = (n * std_ - st * sd) / den, a = (sd - b * st) / n;
    size_t worst = 0;
    double worst_r = -1.0;
    for (size_t k = 0; k < td.size(); ++k) {
      const double r = std::abs(td[k].second - (a + b * td[k].first));
      if (r > worst_r) {
        worst_r = r;
        worst = k;
      }
    }
    if (worst_r <= tolerance) {
      *d0 = a;
      *d1 = a + b;
      return true;
    }
    td.erase(td.begin() + static_cast<std::ptrdiff_t>(worst));
  }
  return false;
}

}  // namespace pl_slam::bench
