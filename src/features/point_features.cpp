#include "pl_slam/features/point_features.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "pl_slam/util/error.h"

namespace pl_slam {

std::string PointDetectorOptions::Validate() const {
  std::ostringstream os;
  if (max_points < 10 || max_points > 20000)
    os << "max_points=" << max_points << " must be in [10, 20000]";
  else if (grid_cols < 1 || grid_cols > 64)
    os << "grid_cols=" << grid_cols << " must be in [1, 64]";
  else if (grid_rows < 1 || grid_rows > 64)
    os << "grid_rows=" << grid_rows << " must be in [1, 64]";
  else if (levels < 1 || levels > 12)
    os << "levels=" << levels << " must be in [1, 12]";
  else if (!(scale_factor > 1.0 && scale_factor <= 2.0))
    os << "scale_factor=" << scale_factor << " must be in (1, 2]";
  else if (fast_threshold < 1 || fast_threshold > 100)
    os << "fast_threshold=" << fast_threshold << " must be in [1, 100]";
  else if (min_fast_threshold < 1 || min_fast_threshold > fast_threshold)
    os << "min_fast_threshold=" << min_fast_threshold << " must be in [1, fast_threshold]";
  else if (!(oversample >= 1.0 && oversample <= 20.0))
    os << "oversample=" << oversample << " must be in [1, 20]";
  return os.str();
}

PointDetector::PointDetector(const PointDetectorOptions& options) : options_(options) {
  const std::string err = options_.Validate();
  if (!err.empty()) throw ConfigError("points." + err);
}

cv::Point2f PyramidLevelToImage(cv::Point2f p, int level, cv::Size image_size, float scale_factor) {
  // Level sizes as ORB computes them (float scale, rounded).
  auto level_size = [&](int l) {
    const float s = static_cast<float>(std::pow(static_cast<double>(scale_factor), l));
    return cv::Size2d(cvRound(image_size.width / s), cvRound(image_size.height / s));
  };
  double x = p.x, y = p.y;
  for (int l = level; l > 0; --l) {
    // cv::resize maps destination pixel centre x to source (x + 0.5) * src/dst - 0.5.
    const cv::Size2d dst = level_size(l), src = level_size(l - 1);
    x = (x + 0.5) * src.width / dst.width - 0.5;
    y = (y + 0.5) * src.height / dst.height - 0.5;
  }
  return cv::Point2f(static_cast<float>(x), static_cast<float>(y));
}

std::vector<cv::KeyPoint> BucketKeypoints(const std::vector<cv::KeyPoint>& keypoints,
                                          cv::Size image_size, int grid_cols, int grid_rows,
                                          int max_keep) {
  if (static_cast<int>(keypoints.size()) <= max_keep) return keypoints;
  const int cells = grid_cols * grid_rows;
  std::vector<std::vector<int>> bucket(cells);
  for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
    const cv::Point2f& p = keypoints[i].pt;
    const int cx =
        std::clamp(static_cast<int>(p.x * grid_cols / image_size.width), 0, grid_cols - 1);
    const int cy =
        std::clamp(static_cast<int>(p.y * grid_rows / image_size.height), 0, grid_rows - 1);
    bucket[cy * grid_cols + cx].push_back(i);
  }
  auto stronger = [&](int a, int b) { return keypoints[a].response > keypoints[b].response; };
  const int quota = std::max(1, max_keep / cells);
  std::vector<char> taken(keypoints.size(), 0);
  std::vector<cv::KeyPoint> out;
  out.reserve(max_keep);
  std::vector<int> leftover;
  for (auto& b : bucket) {
    std::sort(b.begin(), b.end(), stronger);
    for (int k = 0; k < static_cast<int>(b.size()); ++k) {
      if (k < quota) {
        out.push_back(keypoints[b[k]]);
        taken[b[k]] = 1;
      } else {
        leftover.push_back(b[k]);
      }
    }
  }
  // Cells without texture leave budget unused: give it to the strongest remaining keypoints.
  if (static_cast<int>(out.size()) < max_keep) {
    const int need = max_keep - static_cast<int>(out.size());
    if (static_cast<int>(leftover.size()) > need) {
      std::nth_element(leftover.begin(), leftover.begin() + need, leftover.end(), stronger);
      leftover.resize(need);
    }
    for (int i : leftover) out.push_back(keypoints[i]);
  } else if (static_cast<int>(out.size()) > max_keep) {
    std::nth_element(
        out.begin(), out.begin() + max_keep, out.end(),
        [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
    out.resize(max_keep);
  }
  return out;
}

namespace {

// ORB's fixed parameters (as cv::ORB::create gets them below): features closer than the edge
// threshold to a level's border are dropped, the descriptor's patch is 31 px, the Harris score
// uses a 7x7 block.
constexpr int kEdgeThreshold = 19;
constexpr int kPatchSize = 31;
constexpr int kHarrisBlock = 7;
constexpr float kHarrisK = 0.04f;

// Level l is level l-1 resized to round(size / s^l), as ORB builds its pyramid. Levels that
// would be less than a pixel wide or high stay empty.
std::vector<cv::Mat> BuildPyramid(const cv::Mat& image, int levels, double scale_factor) {
  std::vector<cv::Mat> pyr(static_cast<std::size_t>(levels));
  pyr[0] = image;
  for (int l = 1; l < levels; ++l) {
    const double s = std::pow(scale_factor, l);
    const cv::Size size(cvRound(image.cols / s), cvRound(image.rows / s));
    if (size.width < 1 || size.height < 1) break;
    cv::resize(pyr[l - 1], pyr[l], size, 0, 0, cv::INTER_LINEAR_EXACT);
  }
  return pyr;
}

// ORB's share of `total` candidates per level: geometric in the level's scale.
std::vector<int> FeaturesPerLevel(int total, int levels, double scale_factor) {
  std::vector<int> n(static_cast<std::size_t>(levels), 0);
  const double factor = 1.0 / scale_factor;
  double desired = total * (1.0 - factor) / (1.0 - std::pow(factor, levels));
  int sum = 0;
  for (int l = 0; l < levels - 1; ++l) {
    n[l] = cvRound(desired);
    sum += n[l];
    desired *= factor;
  }
  n[levels - 1] = std::max(total - sum, 0);
  return n;
}

// Harris corner score over a 7x7 block of 3x3 Sobel gradients, scaled as ORB scales it (so the
// responses of all levels compare). `p` lies at least kEdgeThreshold from the border.
float HarrisScore(const cv::Mat& img, cv::Point2f p) {
  const int r = kHarrisBlock / 2;
  const int x0 = cvRound(p.x) - r, y0 = cvRound(p.y) - r;
  const int step = static_cast<int>(img.step);
  long long a = 0, b = 0, c = 0;
  for (int y = 0; y < kHarrisBlock; ++y) {
    const uchar* q = img.ptr<uchar>(y0 + y) + x0;
    for (int x = 0; x < kHarrisBlock; ++x, ++q) {
      const int ix =
          (q[1] - q[-1]) * 2 + (q[-step + 1] - q[-step - 1]) + (q[step + 1] - q[step - 1]);
      const int iy =
          (q[step] - q[-step]) * 2 + (q[step - 1] - q[-step - 1]) + (q[step + 1] - q[-step + 1]);
      a += ix * ix;
      b += iy * iy;
      c += ix * iy;
    }
  }
  const float scale = 1.0f / (4 * kHarrisBlock * 255.0f);
  const float s4 = scale * scale * scale * scale;
  const float fa = static_cast<float>(a), fb = static_cast<float>(b), fc = static_cast<float>(c);
  return (fa * fb - fc * fc - kHarrisK * (fa + fb) * (fa + fb)) * s4;
}

// Half-widths of the rows of the circular patch (radius 15) the orientation is measured over,
// made symmetric about the diagonal.
const std::vector<int>& PatchRowHalfWidths() {
  static const std::vector<int> umax = [] {
    const int half = kPatchSize / 2;
    std::vector<int> u(half + 2, 0);
    const int vmax = cvFloor(half * std::sqrt(2.0) / 2 + 1);
    const int vmin = cvCeil(half * std::sqrt(2.0) / 2);
    for (int v = 0; v <= vmax; ++v)
      u[v] = cvRound(std::sqrt(static_cast<double>(half * half - v * v)));
    for (int v = half, v0 = 0; v >= vmin; --v) {
      while (u[v0] == u[v0 + 1]) ++v0;
      u[v] = v0;
      ++v0;
    }
    return u;
  }();
  return umax;
}

// ORB's orientation: the direction from the keypoint to the intensity centroid of its patch,
// in degrees [0, 360).
float CentroidAngle(const cv::Mat& img, cv::Point2f p) {
  const std::vector<int>& umax = PatchRowHalfWidths();
  const int half = kPatchSize / 2;
  const uchar* c = img.ptr<uchar>(cvRound(p.y)) + cvRound(p.x);
  const int step = static_cast<int>(img.step);
  int m10 = 0, m01 = 0;
  for (int u = -half; u <= half; ++u) m10 += u * c[u];
  for (int v = 1; v <= half; ++v) {
    int diff = 0;
    for (int u = -umax[v]; u <= umax[v]; ++u) {
      const int below = c[u + v * step], above = c[u - v * step];
      diff += below - above;
      m10 += u * (below + above);
    }
    m01 += v * diff;
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

// ORB's candidates at one FAST threshold: per level, the 2n strongest FAST corners away from
// the border, of which the n with the best Harris score stay (n: the level's share of `total`).
// Positions as ORB reports them: level coordinates times s^level (`level_scale`). No orientation
// yet: it is computed for the few that survive bucketing.
std::vector<cv::KeyPoint> Candidates(const std::vector<cv::Mat>& pyr, int threshold, int total,
                                     double scale_factor, const std::vector<float>& level_scale) {
  const int levels = static_cast<int>(pyr.size());
  const std::vector<int> share = FeaturesPerLevel(total, levels, scale_factor);
  std::vector<cv::KeyPoint> all, level;
  for (int l = 0; l < levels; ++l) {
    if (share[l] <= 0 || pyr[l].empty()) continue;
    level.clear();
    cv::FAST(pyr[l], level, threshold, true);
    cv::KeyPointsFilter::runByImageBorder(level, pyr[l].size(), kEdgeThreshold);
    cv::KeyPointsFilter::retainBest(level, 2 * share[l]);
    for (cv::KeyPoint& kp : level) kp.response = HarrisScore(pyr[l], kp.pt);
    cv::KeyPointsFilter::retainBest(level, share[l]);
    const float s = level_scale[l];
    for (cv::KeyPoint& kp : level) {
      kp.octave = l;
      kp.size = kPatchSize * s;
      kp.pt *= s;
      all.push_back(kp);
    }
  }
  return all;
}

}  // namespace

void PointDetector::Detect(const cv::Mat& image, std::vector<cv::KeyPoint>* keypoints,
                           cv::Mat* descriptors) const {
  keypoints->clear();
  *descriptors = cv::Mat();
  if (image.empty()) return;
  if (image.type() != CV_8UC1) {
    throw InputError("PointDetector::Detect: image must be CV_8UC1, got type " +
                     std::to_string(image.type()));
  }
  const int candidates = static_cast<int>(options_.max_points * options_.oversample);
  const double sf = options_.scale_factor;
  const std::vector<cv::Mat> pyr = BuildPyramid(image, options_.levels, sf);
  std::vector<float> level_scale(pyr.size());  // s^level
  for (std::size_t l = 0; l < pyr.size(); ++l)
    level_scale[l] = static_cast<float>(std::pow(sf, static_cast<double>(l)));
  // ORB's keypoints (FAST, ranked by Harris per level), computed here so that the orientation
  // is measured only for the keypoints bucketing keeps, not for the whole candidate pool.
  std::vector<cv::KeyPoint> all =
      Candidates(pyr, options_.fast_threshold, candidates, sf, level_scale);
  // A textured image fills the pool at the normal threshold; a poor one (fewer corners in all
  // than are to be kept: plain walls) is searched again at the low-contrast threshold, on
  // every pyramid level, and as ORB-SLAM does, only the grid cells the normal threshold left
  // empty take those weaker corners: where a cell has real corners, low-contrast ones (noise
  // on a faint gradient, blurred edges) would only dilute them.
  if (options_.min_fast_threshold < options_.fast_threshold &&
      static_cast<int>(all.size()) < options_.max_points) {
    const int cols = options_.grid_cols, rows = options_.grid_rows;
    auto cell = [&](const cv::Point2f& p) {
      const int cx = std::clamp(static_cast<int>(p.x * cols / image.cols), 0, cols - 1);
      const int cy = std::clamp(static_cast<int>(p.y * rows / image.rows), 0, rows - 1);
      return cy * cols + cx;
    };
    std::vector<char> occupied(static_cast<std::size_t>(cols * rows), 0);
    for (const cv::KeyPoint& kp : all) occupied[cell(kp.pt)] = 1;
    for (const cv::KeyPoint& kp :
         Candidates(pyr, options_.min_fast_threshold, candidates, sf, level_scale))
      if (!occupied[cell(kp.pt)]) all.push_back(kp);
  }
  if (all.empty()) return;
  *keypoints = BucketKeypoints(all, image.size(), options_.grid_cols, options_.grid_rows,
                               options_.max_points);
  for (cv::KeyPoint& kp : *keypoints)
    kp.angle = CentroidAngle(pyr[kp.octave], kp.pt / level_scale[kp.octave]);
  const float sff = static_cast<float>(sf);
  // Descriptors only for the kept keypoints, at their orientation (ORB may drop a few near the
  // border).
  cv::Ptr<cv::ORB> orb =
      cv::ORB::create(options_.max_points, sff, options_.levels, kEdgeThreshold, 0, 2,
                      cv::ORB::HARRIS_SCORE, kPatchSize, options_.fast_threshold);
  orb->compute(image, *keypoints, *descriptors);
  // Descriptors are computed; now move the keypoints to where they are in the image.
  for (cv::KeyPoint& kp : *keypoints) {
    if (kp.octave <= 0) continue;
    kp.pt = PyramidLevelToImage(kp.pt / level_scale[kp.octave], kp.octave, image.size(), sff);
  }
}

}  // namespace pl_slam
