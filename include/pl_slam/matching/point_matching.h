// Point correspondences: left-right (stereo, along the epipolar row) and frame to frame
// (guided by a motion prediction when one is available).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Options of point matching.
struct PointMatchingOptions {
  int max_distance = 64;      ///< largest accepted Hamming distance (of 256 bits)
  double stereo_ratio = 0.8;  ///< stereo: best < ratio * second best
  double stereo_row_tolerance =
      2.0;                       ///< stereo: |v_l - v_r| in pixels at octave 0 (scaled per octave)
  double min_disparity = 0.5;    ///< stereo: smaller disparities are rejected (pixels)
  double max_disparity = 200.0;  ///< stereo: largest disparity searched (pixels)
  bool subpixel = true;          ///< stereo: refine the disparity by patch correlation
  /// Stereo: a match is kept only when the 11x11 patches around it, at the final (refined)
  /// disparity, reach this zero-mean normalised cross-correlation; 0 = no check. Two corners
  /// with close descriptors on one row are not always one point (a faint corner beside another,
  /// a corner the other camera sees against another background): their disparity can be pixels
  /// off, which frame-to-frame residuals hardly show (a depth error moves a point's projection
  /// only by its share of the motion's parallax). Off by default: it removes most such depths
  /// but does not make trajectories better; see docs/BENCHMARKS.md, design decisions.
  double stereo_min_zncc = 0.0;
  /// Stereo, in an image where descriptor matching gave fewer than row_search_below stereo
  /// points: a left keypoint left without a partner (the right image's detector missed that
  /// corner, common at low contrast) is looked for along its row by zero-mean normalised
  /// cross-correlation (ZNCC) of an 11x11 patch; accepted when the best column reaches
  /// row_search_min_zncc, has fallen 3 px to either side (not an edge), and beats by
  /// row_search_margin every column past the slopes that fall away from it (however slowly a
  /// blurred corner's correlation falls); its column is then refined by intensity fit alone.
  int row_search_below = 150;
  double row_search_min_zncc = 0.9;  ///< see row_search_below; 0 = no row search
  double row_search_margin = 0.2;    ///< see row_search_below
  double f2f_ratio = 0.8;            ///< frame to frame: best < ratio * second best
  /// Ratio tests (stereo and frame to frame): a candidate within this many pixels of the best
  /// one is the same corner detected again (another pyramid level, a neighbouring pixel) and
  /// is not counted as its rival; 0 = every other candidate is a rival. Off by default: see
  /// docs/BENCHMARKS.md, design decisions.
  double same_corner_radius = 0.0;
  double search_radius = 30.0;  ///< frame to frame with a prediction: radius, pixels
  /// Frame to frame (and against the last keyframe): a matched point's position in the
  /// current image is where the reference image's 11x11 patch around the reference keypoint
  /// aligns (matching/patch_alignment.h), not the current keypoint itself, when the alignment
  /// converges within this many pixels of the keypoint and the predicted motion does not warp
  /// the patch; 0 = the keypoints as detected. A corner detector's position moves with the
  /// image content only to within its pixel grid and its own response, the patch follows the
  /// texture. See docs/BENCHMARKS.md, design decisions.
  double f2f_align_max_shift = 0.0;

  /// Empty when valid, else "key=value must be ..." for the first bad field.
  std::string Validate() const;
};

/// Hamming distance of two 32-byte binary descriptors.
int HammingDistance32(const uint8_t* a, const uint8_t* b);

/// Builds the left-image point features from left and right keypoints: every left keypoint
/// becomes a PointFeature, with has_depth/disparity/p_c set when it has a mutual-best stereo
/// match on its epipolar row within the disparity range passing the ratio test, or else (see
/// row_search_min_zncc) a unique correlation peak on its row, and its patches agree there (see
/// stereo_min_zncc). Returns the number of stereo matches.
int MatchStereoPoints(const StereoCamera& camera, const cv::Mat& left_image,
                      const cv::Mat& right_image, const std::vector<cv::KeyPoint>& left_kp,
                      const cv::Mat& left_desc, const std::vector<cv::KeyPoint>& right_kp,
                      const cv::Mat& right_desc, const PointMatchingOptions& options,
                      PointFeatures* points);

/// Frame-to-frame matches (previous index, current index) of previous points that have depth.
/// With `T_cur_prev` the previous 3D points are projected into the current image and only
/// current points within search_radius are candidates; without it every current point is.
/// Matches are mutual best and pass the ratio test.
std::vector<std::pair<int, int>> MatchPointsFrameToFrame(
    const StereoCamera& camera, const PointFeatures& prev, const cv::Mat& prev_desc,
    const PointFeatures& cur, const cv::Mat& cur_desc, const PointMatchingOptions& options,
    const SE3* T_cur_prev = nullptr);

/// Frame-to-frame matches guided by the prediction `T_cur_prev`; when they are fewer than
/// `everywhere_below`, the prediction may be wrong (a sudden change of motion) and every
/// current point is searched as well: the search with more matches is kept. Where corners
/// repeat (the same pattern along a wall) the search everywhere refuses them all to the ratio
/// test, so it must not replace a prediction that told them apart.
std::vector<std::pair<int, int>> MatchPointsPredicted(
    const StereoCamera& camera, const PointFeatures& prev, const cv::Mat& prev_desc,
    const PointFeatures& cur, const cv::Mat& cur_desc, const PointMatchingOptions& options,
    const SE3& T_cur_prev, int everywhere_below);

}  // namespace pl_slam
