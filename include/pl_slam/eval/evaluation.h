// One-call trajectory evaluation (association, alignment, ATE, RPE, coverage) and its text
// and JSON reports. Used by the pl_slam_evaluate tool and by regression tests.
#pragma once

#include <string>
#include <vector>

#include "pl_slam/eval/alignment.h"
#include "pl_slam/eval/association.h"
#include "pl_slam/eval/metrics.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {

/// Options of EvaluateTrajectory.
struct EvaluationOptions {
  double max_dt = 0.02;                             ///< association window, seconds; > 0
  bool interpolate = true;                          ///< interpolate ground truth in time
  AlignmentMode alignment = AlignmentMode::kSE3;    ///< alignment of the main ATE / RPE
  std::vector<int> rpe_frame_deltas = {1, 10};      ///< RPE frame steps; each >= 1
  std::vector<double> rpe_lengths = {1, 2, 5, 10};  ///< RPE segment lengths, m; each > 0

  /// Throws ConfigError naming the bad key and its allowed range.
  void Validate() const;
};

/// Everything EvaluateTrajectory measures.
struct EvaluationResult {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  EvaluationOptions options;
  std::size_t est_poses = 0;  ///< poses in the estimate
  std::size_t gt_poses = 0;   ///< poses in the ground truth
  Association association;    ///< matched pairs (gt interpolated at estimate times)
  AteResult ate;              ///< with options.alignment
  Trajectory est_aligned;     ///< associated estimate after options.alignment
  bool se3_valid = false;     ///< ate_se3 computed
  AteResult ate_se3;          ///< always attempted, for the summary table
  bool sim3_valid = false;    ///< ate_sim3 computed (false for degenerate input)
  std::string sim3_note;      ///< why Sim3 was not computed
  AteResult ate_sim3;
  std::vector<RpeFramesResult> rpe_frames;      ///< one per options.rpe_frame_deltas
  std::vector<RpeDistanceResult> rpe_distance;  ///< one per options.rpe_lengths
  double gt_path_length = 0.0;                  ///< path length of the associated ground truth, m
  double est_duration = 0.0;                    ///< time span of the associated pairs, s
  CoverageResult coverage;
};

/// Evaluates `est` against `gt`. `frame_times` are the stamps of the frames the estimate
/// should cover (e.g. image stamps); empty -> the ground-truth stamps. RPE is computed on the
/// aligned estimate (matters only for Sim3, whose scale changes relative translations).
/// Throws InputError for an empty estimate or ground truth, when no estimate pose has ground
/// truth within max_dt, or when the requested alignment is degenerate; ConfigError for bad
/// options.
EvaluationResult EvaluateTrajectory(const Trajectory& est, const Trajectory& gt,
                                    const std::vector<double>& frame_times,
                                    const EvaluationOptions& options = {});

/// A short human-readable table of the result (ATE SE3/Sim3, scale, RPE rows, coverage,
/// counts); `name` heads it when not empty.
std::string FormatEvaluationTable(const EvaluationResult& result, const std::string& name);

/// The result as a JSON object (hand formatted, metrics without samples are null).
std::string FormatEvaluationJson(const EvaluationResult& result, const std::string& name);

}  // namespace eval
}  // namespace pl_slam
