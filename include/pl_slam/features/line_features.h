// Line segments with LBD binary descriptors for one image (paper Section IV-B). The default
// detector chains Canny-style edges (non-maximum suppression, hysteresis per chain) and
// splits the chains into straight runs: the FastLineDetector idea, re-implemented with SIMD,
// without per-pixel allocations and with sub-pixel edge positions. OpenCV's LSD stays
// selectable for comparison. Descriptors are computed only for the lines that are kept, on
// the gradient images the detector already computed.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "pl_slam/features/stereo_features.h"

namespace pl_slam {

/// Which segment detector LineDetector runs.
enum class LineDetectorKind {
  kEdgeChain,  ///< edges chained and split into straight runs (fast, the default)
  kLsd,        ///< OpenCV LSD (cv::createLineSegmentDetector, no refinement); ~6x slower
};

/// Options of the line detector. Lengths are relative to min(width, height) so one setting
/// fits EuRoC (752x480) and KITTI (1241x376) alike.
struct LineDetectorOptions {
  LineDetectorKind detector = LineDetectorKind::kEdgeChain;  ///< segment detector
  double min_length_ratio = 0.05;  ///< shortest kept segment, fraction of min(width, height)
  int max_lines = 120;             ///< keep at most this many, the longest first (0 = no cap)
  /// Under the cap, segments within this angle of the image rows (no stereo depth) rank after
  /// all steeper ones; 0 = longest first regardless of direction.
  double prefer_steep_deg = 15.0;
  double canny_low = 40.0;   ///< edge chain: Canny low threshold on |dx|+|dy| (Sobel)
  double canny_high = 80.0;  ///< edge chain: Canny high threshold, one pixel per chain
  /// Edge chain: an image that gives fewer segments than this is searched again with the
  /// low-contrast thresholds below (plain walls: door frames and skirting a few grey levels
  /// off the paint). 0 = never.
  int min_lines = 40;
  double low_contrast_canny_low = 15.0;   ///< edge chain: Canny low threshold of that search
  double low_contrast_canny_high = 30.0;  ///< edge chain: Canny high threshold of that search
  /// Edge chain, in an image that gives min_lines segments or more but fewer than max_lines:
  /// the low-contrast search runs again in the cells of this many pixels that no segment of
  /// the first search crosses (a faint door frame on the plain wall beside a poster), its
  /// segments added to the first search's. 0 = never.
  int low_contrast_cell = 64;
  double max_fit_distance = 1.0;    ///< edge chain: pixel-to-line distance that ends a straight run
  bool merge_collinear = true;      ///< join collinear pieces split at junctions (both detectors)
  double merge_max_gap = 8.0;       ///< merge: largest gap between pieces along the line, pixels
  double merge_max_distance = 1.5;  ///< merge: largest endpoint-to-line distance, pixels
  double merge_max_angle_deg = 2.0;  ///< merge: largest direction difference, degrees
  double lsd_scale = 0.8;            ///< LSD: image scale LSD works at (its own default)

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// Detects line segments and their LBD descriptors. Detect() may run concurrently from
/// several threads on one detector (the left and right images at once): each call borrows
/// its own set of image buffers from an internal pool, which keeps them for later calls.
/// Copies share that pool.
class LineDetector {
 public:
  /// Throws ConfigError naming the bad key when options.Validate() fails.
  explicit LineDetector(const LineDetectorOptions& options);

  /// Detects the segments of `image` (CV_8UC1; empty gives nothing) and computes their LBD
  /// descriptors (CV_8U, 32 bytes, row i = line i). Lines come longest first, oriented so
  /// that the brighter side lies to the right of s -> e in the image (x right, y down), which
  /// makes `angle` comparable across images over the full circle. Only s, e, l, angle,
  /// length and octave (always 0) are set; depth comes from stereo matching.
  void Detect(const cv::Mat& image, LineFeatures* lines, cv::Mat* descriptors) const;

  /// The options in use.
  const LineDetectorOptions& options() const { return options_; }

  /// Reusable buffers of Detect() (defined in the source file).
  struct WorkspacePool;

 private:
  LineDetectorOptions options_;
  std::shared_ptr<WorkspacePool> pool_;
};

/// A LineFeature from its endpoints: fills s, e, the normalised line l, angle and length
/// (octave 0, no depth). Endpoints must differ.
LineFeature MakeLineFeature(const Eigen::Vector2d& s, const Eigen::Vector2d& e);

/// LBD descriptors (Zhang & Koch 2013) of `lines` in `image` (CV_8UC1): bit-compatible with
/// OpenCV's cv::line_descriptor::BinaryDescriptor::compute at octave 0 with default
/// parameters (9 bands of 7 pixels, gradients of the 5x5 sigma-1 Gaussian-blurred image),
/// but several times faster. Row i of `descriptors` (CV_8U, 32 bytes) describes line i.
void ComputeLbdDescriptors(const cv::Mat& image, const LineFeatures& lines, cv::Mat* descriptors);

}  // namespace pl_slam
