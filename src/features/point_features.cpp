#include "pl_slam/features/point_features.h"

#include <algorithm>
#include <cmath>
#include <sstream>

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

void PointDetector::Detect(const cv::Mat& image, std::vector<cv::KeyPoint>* keypoints,
                           cv::Mat* descriptors) const {
  keypoints->clear();
  *descriptors = cv::Mat();
  if (image.empty()) return;
  const int candidates = static_cast<int>(options_.max_points * options_.oversample);
  cv::Ptr<cv::ORB> orb =
      cv::ORB::create(candidates, static_cast<float>(options_.scale_factor), options_.levels, 19, 0,
                      2, cv::ORB::HARRIS_SCORE, 31, options_.fast_threshold);
  std::vector<cv::KeyPoint> all;
  orb->detect(image, all);
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
    std::vector<cv::KeyPoint> weak;
    orb->setFastThreshold(options_.min_fast_threshold);
    orb->detect(image, weak);
    for (const cv::KeyPoint& kp : weak)
      if (!occupied[cell(kp.pt)]) all.push_back(kp);
  }
  if (all.empty()) return;
  *keypoints = BucketKeypoints(all, image.size(), options_.grid_cols, options_.grid_rows,
                               options_.max_points);
  // Descriptors only for the kept keypoints (ORB may drop a few near the border).
  orb->compute(image, *keypoints, *descriptors);
  // Descriptors are computed; now move the keypoints to where they are in the image.
  const float sf = static_cast<float>(options_.scale_factor);
  for (cv::KeyPoint& kp : *keypoints) {
    if (kp.octave <= 0) continue;
    const float s = static_cast<float>(std::pow(static_cast<double>(sf), kp.octave));
    kp.pt = PyramidLevelToImage(kp.pt / s, kp.octave, image.size(), sf);
  }
}

}  // namespace pl_slam
