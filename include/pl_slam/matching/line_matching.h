// Line-segment correspondences (paper Section IV-B): left-right matching with endpoint
// triangulation, and frame-to-frame matching, optionally gated by a motion prediction.
// Matches are mutual best LBD matches that pass a ratio test among the candidates that
// survive the geometric filters (orientation, length, epipolar overlap, disparities).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Options of line matching. Angles compare full-circle directions: detectors orient every
/// segment by its contrast polarity, so edges of opposite polarity never match.
struct LineMatchingOptions {
  int max_distance = 90;                 ///< largest accepted Hamming distance (of 256 bits)
  double stereo_ratio = 0.8;             ///< stereo: best < ratio * second best candidate
  double stereo_max_angle_deg = 10.0;    ///< stereo: largest left-right direction difference
  double stereo_min_length_ratio = 0.5;  ///< stereo: shorter / longer segment length
  double stereo_min_row_overlap = 0.5;   ///< stereo: shared rows / rows of the longer segment
  double min_disparity = 1.0;            ///< stereo: both endpoint disparities at least this (px)
  double max_disparity = 200.0;          ///< stereo: both endpoint disparities at most this (px)
  double max_disparity_gradient = 0.5;   ///< stereo: |d_s - d_e| / left length (3D slant bound)
  double min_stereo_angle_deg = 15.0;    ///< stereo: flatter segments (vs. rows) get no depth
  /// stereo: a flatter segment whose both ends are L junctions with segments that have depth
  /// takes their disparities there when the right image shows it between the same junctions
  /// within this distance (px); 0: flat segments get no depth
  double junction_max_px = 3.0;
  /// stereo: a flat segment with an L junction at one end only takes that junction's disparity
  /// there when the right segment starts within junction_max_px of where it puts it, and at
  /// its free end (away from the image border) the disparity of the end's 11x11 patch, searched
  /// on its row near the right segment's end (MatchStereoLines needs the images for this)
  bool junction_one_end = true;
  double f2f_ratio = 0.8;               ///< frame to frame: best < ratio * second best
  double f2f_max_angle_deg = 15.0;      ///< frame to frame: largest direction difference
  double f2f_min_length_ratio = 0.4;    ///< frame to frame: shorter / longer segment length
  double f2f_max_line_distance = 10.0;  ///< with prediction: predicted endpoints to line (px)
  double f2f_max_gap = 20.0;            ///< with prediction: gap between the segments (px)

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// A motion prior for frame-to-frame matching: previous lines with depth are projected into
/// the current image and only current segments close to the projection are candidates.
struct LinePrediction {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  SE3 T_cur_prev;       ///< predicted pose of the previous camera in the current camera frame
  StereoCamera camera;  ///< intrinsics of both frames
};

/// Hamming distance of two 32-byte binary descriptors.
int LineDescriptorDistance(const uint8_t* a, const uint8_t* b);

/// Stereo-matches the lines of a rectified pair and triangulates the matched left lines:
/// for each endpoint of a left segment, the disparity is measured where the right segment's
/// infinite line crosses that endpoint's row, and both endpoints are back-projected
/// (P_c, Q_c, has_depth = true). Segments within min_stereo_angle_deg of the rows (nearly
/// parallel to the baseline) are not matched: the row crossing is ill-conditioned there, so
/// they keep has_depth = false and serve as 2D observations only, unless both their ends are
/// L junctions with matched segments (a frame's corners, a lintel on its jambs): then they
/// take those segments' disparities there when the right image shows them between the same
/// junctions (junction_max_px); with junction_one_end and the images, also when one end is such
/// a junction and the other end's patch is found on its row near the right segment's end.
/// Every other left line without a valid match is reset to has_depth = false too. Returns the
/// number of left lines with depth. With `right_of_left`, it receives the matched right index
/// per left line (-1 when none). Throws ConfigError on invalid options, InputError on
/// descriptors that do not fit the lines.
int MatchStereoLines(const StereoCamera& camera, LineFeatures* left, const cv::Mat& left_desc,
                     const LineFeatures& right, const cv::Mat& right_desc,
                     const LineMatchingOptions& options, std::vector<int>* right_of_left = nullptr,
                     const cv::Mat& left_image = cv::Mat(), const cv::Mat& right_image = cv::Mat());

/// Frame-to-frame matches (previous index, current index): mutual best LBD matches that pass
/// the ratio test. Without a prediction the ratio test runs against every current segment
/// (descriptor distinctiveness in the whole image) and the best one must then agree in
/// direction (f2f_max_angle_deg) and length (f2f_min_length_ratio). With `prediction`,
/// previous lines that have depth are projected into the current image and only current
/// segments whose line passes within f2f_max_line_distance of both projected endpoints,
/// overlapping the projection up to f2f_max_gap and agreeing with its direction and length,
/// are candidates; previous lines without depth, or projecting behind the camera, are matched
/// as without prediction. Throws ConfigError on invalid options, InputError on descriptors
/// that do not fit the lines.
std::vector<std::pair<int, int>> MatchLines(const LineFeatures& prev, const cv::Mat& prev_desc,
                                            const LineFeatures& cur, const cv::Mat& cur_desc,
                                            const LineMatchingOptions& options,
                                            const LinePrediction* prediction = nullptr);

/// MatchLines with `prediction`; when that gives fewer than `everywhere_below` matches, also
/// without it, keeping the one with more matches (as MatchPointsPredicted).
std::vector<std::pair<int, int>> MatchLinesPredicted(
    const LineFeatures& prev, const cv::Mat& prev_desc, const LineFeatures& cur,
    const cv::Mat& cur_desc, const LineMatchingOptions& options, const LinePrediction& prediction,
    int everywhere_below);

}  // namespace pl_slam
