// Trajectory error metrics: absolute trajectory error (ATE), relative pose error (RPE) per
// frame delta and per travelled distance (KITTI-style drift), and frame coverage.
//
// Every result is NaN-free: a metric with no samples has count == 0 and zero values, and
// printers show it as "n/a" (JSON: null).
#pragma once

#include <cstddef>
#include <vector>

#include "pl_slam/eval/alignment.h"
#include "pl_slam/eval/association.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {

/// Summary statistics of a set of non-negative errors.
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;  ///< population standard deviation about the mean
  double min = 0.0;
  double max = 0.0;
};

/// Statistics of `errors` (any order); all zero with count 0 for an empty input.
ErrorStats ComputeErrorStats(const std::vector<double>& errors);

/// Absolute trajectory error after alignment.
struct AteResult {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Alignment alignment;                     ///< estimate world -> ground-truth world
  ErrorStats translation;                  ///< ||p_gt - p_est_aligned||, metres
  ErrorStats rotation_deg;                 ///< angle(R_gt^T R_est_aligned), degrees
  std::vector<double> times;               ///< time stamp of each pair, seconds
  std::vector<double> translation_errors;  ///< per pair, metres (same order as times)
};

/// Aligns the associated estimate with `mode` and measures the absolute error per pair.
/// Throws InputError when the association is empty or the alignment is degenerate (Sim3 on
/// identical positions).
AteResult ComputeAte(const Association& association, AlignmentMode mode);

/// Relative pose error over a fixed number of associated frames.
struct RpeFramesResult {
  int delta = 1;            ///< frame step between the two poses of a pair
  ErrorStats translation;   ///< ||t(E)||, metres, E = (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j)
  ErrorStats rotation_deg;  ///< angle(E), degrees
};

/// RPE over pairs (i, i + delta) of associated poses. `est` must already be aligned when
/// the alignment has a scale (rigid alignment does not change relative poses). Pairs are
/// counted in associated frames; with fewer than delta + 1 poses the result has count 0.
RpeFramesResult ComputeRpeFrames(const Trajectory& est, const Trajectory& gt, int delta);

/// Drift over segments of a given length along the ground-truth path (KITTI odometry
/// protocol): for every start frame i, j is the first frame with path(j) - path(i) >= L;
/// translational drift = ||t(E)|| / L, rotational drift = angle(E) / L.
struct RpeDistanceResult {
  double length = 0.0;              ///< segment length L, metres
  std::size_t segments = 0;         ///< number of segments; 0 when L exceeds the path
  double translation_pct = 0.0;     ///< mean ||t(E)|| / L * 100, percent
  double rotation_deg_per_m = 0.0;  ///< mean angle(E) / L, degrees per metre
  ErrorStats translation;           ///< ||t(E)||, metres, over the segments
};

/// Per-distance RPE for each length (lengths <= 0 or longer than the ground-truth path get
/// segments == 0). `est` must already be aligned when the alignment has a scale.
std::vector<RpeDistanceResult> ComputeRpeDistance(const Trajectory& est, const Trajectory& gt,
                                                  const std::vector<double>& lengths);

/// Length of the path through the positions of `traj`, metres.
double PathLength(const Trajectory& traj);

/// Share of frames that have an estimate.
struct CoverageResult {
  std::size_t frames = 0;   ///< frame time stamps considered
  std::size_t covered = 0;  ///< frames with an estimate within max_dt
  double ratio = 0.0;       ///< covered / frames (0 when there are no frames)
};

/// A frame counts as covered when it is the nearest frame, within max_dt, of some estimate
/// pose: each estimate covers at most one frame, so 20 Hz estimates against 200 Hz frame
/// stamps give about 0.1. `frame_times` need not be sorted.
CoverageResult ComputeCoverage(const std::vector<double>& frame_times, const Trajectory& est,
                               double max_dt);

}  // namespace eval
}  // namespace pl_slam
