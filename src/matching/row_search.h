// Patch correlation along a rectified row, shared by stereo point matching (keypoints without a
// right partner, point_matching.cpp) and the free ends of flat segments (line_matching.cpp).
// Not part of the public API.
#pragma once

#include <opencv2/core.hpp>

namespace pl_slam {
namespace match_internal {

/// Half size of the 11x11 stereo patches: SAD refinement, row search, intensity fit and the
/// patch check of point_matching.cpp, and the free ends of flat segments.
constexpr int kStereoPatchHalf = 5;

/// Box sums of the right image for SearchRow, computed on first use (most frames need none).
struct RightSums {
  cv::Mat sum, sqsum;  // cv::integral of the right image: CV_32S and CV_64F
  void Ensure(const cv::Mat& right);
};

/// Searches the right image's row v0 for the 11x11 patch around left pixel (u0, v0), over the
/// right columns [c0, c1]: the column of the highest zero-mean normalised cross-correlation, with
/// a parabola through it and its neighbours. False when the best is under min_zncc, on the
/// range's border, less than 0.03 above the columns 3 px to either side (a patch on an edge),
/// or not `margin` above every column past the slopes that fall away from it (a repeated
/// patch), or when the left patch is flat.
bool SearchRow(const cv::Mat& left, const cv::Mat& right, RightSums* sums, int u0, int v0, int c0,
               int c1, double min_zncc, double margin, double* ur);

}  // namespace match_internal
}  // namespace pl_slam
