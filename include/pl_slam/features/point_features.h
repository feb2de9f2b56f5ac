// ORB keypoints spread over the image by grid bucketing, with descriptors computed only for
// the keypoints that are kept.
#pragma once

#include <string>

#include <opencv2/features2d.hpp>

#include "pl_slam/features/stereo_features.h"

namespace pl_slam {

/// Options of the point detector.
struct PointDetectorOptions {
  int max_points = 800;       ///< keypoints kept per image after bucketing
  int grid_cols = 8;          ///< bucketing grid columns
  int grid_rows = 6;          ///< bucketing grid rows
  int levels = 4;             ///< ORB pyramid levels
  double scale_factor = 1.2;  ///< ORB pyramid scale step
  int fast_threshold = 20;    ///< FAST corner threshold
  /// An image with fewer corners than max_points at fast_threshold (plain walls) is searched
  /// again at this lower threshold, and the grid cells without a corner at fast_threshold take
  /// what it finds, so low-contrast corners of door frames, skirting and shelves are found;
  /// textured images and textured cells are left as they are. fast_threshold = off.
  int min_fast_threshold = 7;
  double oversample = 8.0;  ///< candidates per kept keypoint before bucketing (large, so
                            ///< texture clusters cannot crowd weak corners out of the pool)

  /// Empty when valid, else "key=value must be ..." for the first bad field.
  std::string Validate() const;
};

/// Detects ORB keypoints and descriptors: a pool of oversample x max_points FAST/Harris
/// candidates ranked per pyramid level as OpenCV's ORB ranks them, then grid bucketing; the
/// orientation is measured only for the keypoints kept, and OpenCV computes their descriptors
/// (keypoints, orientations and descriptors equal cv::ORB's detect + bucketing + compute). A
/// region with more corners than the whole pool (e.g. per-pixel noise) can still crowd out weak
/// ones elsewhere. Detect() is const and may run concurrently from several threads (each call
/// has its own pyramid and OpenCV descriptor extractor).
class PointDetector {
 public:
  /// Throws ConfigError on invalid options.
  explicit PointDetector(const PointDetectorOptions& options);

  /// Detects up to max_points keypoints spread over the grid, with descriptors (row i =
  /// keypoint i). An empty or featureless image gives zero keypoints.
  void Detect(const cv::Mat& image, std::vector<cv::KeyPoint>* keypoints,
              cv::Mat* descriptors) const;

  const PointDetectorOptions& options() const { return options_; }

 private:
  PointDetectorOptions options_;
};

/// Where pixel `p` of OpenCV ORB's pyramid level `level` lies in the full image. ORB builds
/// level l by resizing level l-1 to round(size / s^l) with pixel centres aligned, but reports a
/// keypoint as its level coordinates times s^l. That ignores the half-pixel centre shift and
/// the rounded level sizes: for s = 1.2 the reported position is off by 0.1 px at level 1 and
/// by ~0.4 px at level 3, the same way in the left and right images. Level 0 is returned as is.
cv::Point2f PyramidLevelToImage(cv::Point2f p, int level, cv::Size image_size, float scale_factor);

/// Keeps the strongest keypoints of each grid cell so that texture clusters cannot take all
/// of `max_keep`: per-cell quota first, then the leftover budget by global response.
std::vector<cv::KeyPoint> BucketKeypoints(const std::vector<cv::KeyPoint>& keypoints,
                                          cv::Size image_size, int grid_cols, int grid_rows,
                                          int max_keep);

}  // namespace pl_slam
