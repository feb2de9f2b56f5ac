// Self-check of a rectified stereo calibration from the images alone: is there a constant
// offset between the measured disparities and the true ones (the right principal point is not
// where the calibration says, the camera's `doffs`)?
//
// Why it is observable without ground truth: the stereo disparity is d = fx * baseline / Z -
// doffs, so a wrong doffs changes the inverse depths of near and far points by the same
// amount, not in proportion: no single motion of the camera then moves every point of frame a
// to where it is seen in a later frame b. Solving for b's pose and doffs together over points
// at many depths separates the two.
// A wrong doffs makes stereo depths wrong by a depth-dependent factor, which shows up as a
// translation scale error that grows with the scene's depth (far scenes, small baselines).
#pragma once
#include <opencv2/core.hpp>
#include <functional>
#include <string>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/io/stereo_source.h"

namespace pl_slam {

/// Options of the stereo calibration self-check.
struct StereoCheckOptions {
  int corners = 1500;      ///< corners tracked per pair
  double max_sigma = 0.3;  ///< pairs with a less certain doffs (px, 1 sigma) are dropped
  double min_translation_ratio = 1.0;  ///< less translation (in baselines): pair dropped
  int min_points = 40;                 ///< fewer usable points: the pair gives no estimate
  double min_disparity_spread = 4.0;   ///< px between the 10th and 90th percentile disparity

  /// Empty when valid, else "key=value must be ..." for the first bad field.
  std::string Validate() const;
};

/// The estimate from one pair of left images (a, b) and the right image of a.
struct StereoPairCheck {
  bool usable = false;
  std::string reason;         ///< why not usable (empty when usable)
  int points = 0;             ///< points in the fit (inliers)
  double doffs = 0.0;         ///< estimated right-minus-left principal point x, px
  double sigma = 0.0;         ///< its standard deviation for 0.5 px tracking noise, px
  double row_offset = 0.0;    ///< median v_right - v_left of the stereo matches, px
  double rotation_deg = 0.0;  ///< rotation between the two frames
  double translation = 0.0;   ///< translation between the two frames, m (with the estimate)
  double disparity_lo = 0.0;  ///< 10th percentile measured disparity of the fit's points, px
  double disparity_hi = 0.0;  ///< 90th percentile
};

/// Estimates doffs from the stereo pairs of frame a and of a later frame b of the same rigid
/// scene (8-bit grey, rectified, `camera`'s size). The camera's own doffs is ignored: the
/// result is the value the images imply.
StereoPairCheck CheckStereoPair(const StereoCamera& camera, const cv::Mat& left_a,
                                const cv::Mat& right_a, const cv::Mat& left_b,
                                const cv::Mat& right_b,
                                const StereoCheckOptions& options = StereoCheckOptions());

/// The pairs' estimates combined.
struct StereoCheckSummary {
  int pairs = 0;           ///< usable pairs
  double doffs = 0.0;      ///< median over usable pairs, px
  double doffs_iqr = 0.0;  ///< interquartile range over usable pairs, px
  /// Standard error of the median, px: 1.25 sigma / sqrt(n) with sigma = IQR / 1.349 and n
  /// the usable pairs over 4 (pairs share frames, so they are not independent).
  double doffs_error = 0.0;
  double row_offset = 0.0;  ///< median row offset, px
};
StereoCheckSummary SummariseStereoChecks(const std::vector<StereoPairCheck>& checks);

/// True when the images' doffs differs from `calibrated` by more than three standard errors
/// of the median and by more than 0.3 px.
bool StereoOffsetDiffers(const StereoCheckSummary& summary, double calibrated);

/// A recording's check: about 40 anchor frames spread over its first `max_frames` frames, each
/// paired with the frames 2, 4, 8 and 16 later (CheckStereoPair on each, against the source's
/// camera). `on_pair(anchor, frame, check)`, when given, sees every pair as it is checked.
struct StereoOffsetMeasurement {
  StereoCheckSummary summary;
  int tried = 0;   ///< pairs checked
  int frames = 0;  ///< frames read
  /// Enough usable pairs (5) for the summary to say anything.
  bool conclusive() const { return summary.pairs >= 5; }
};
/// Frames between two anchors of MeasureStereoOffset over `frames` frames (about 40 anchors).
int StereoOffsetAnchorStride(int frames);
StereoOffsetMeasurement MeasureStereoOffset(
    StereoSource* source, int max_frames,
    const std::function<void(int, int, const StereoPairCheck&)>& on_pair = {});

}  // namespace pl_slam
