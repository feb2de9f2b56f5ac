// Bundle adjustment over keyframe poses, point landmarks and line landmarks (paper Section V,
// eqs. 4-6): Levenberg-Marquardt in Ceres with the analytic costs of point_cost.h and
// line_cost.h, SE(3) poses on SE3Manifold, a robust (Huber) loss, sparse Schur elimination of
// the landmarks with SuiteSparse, and outlier observations flagged after the optimisation.
// ROS-free and map-free: the local mapper copies a window of the map into a BaProblem, solves
// it without holding the map lock, and writes the result back.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Options of SolveBundleAdjustment.
struct BundleAdjustmentOptions {
  int max_iterations = 3;  ///< Levenberg-Marquardt iterations per pass (see BENCHMARKS)
  /// Re-optimise without the outliers of the first pass, as ORB-SLAM's local BA does. The
  /// Huber loss still lets a wrong line observation pull the first pass' solution; removed,
  /// street slam's held-out median ATE fell from 0.045 to 0.026 m (BENCHMARKS, design
  /// decisions). It doubles the time of local BA (corridor median 11 -> 23 ms).
  bool second_pass = true;
  /// Pixels (at octave 0) per unit of the chi2 outlier gates below: an observation is flagged
  /// after the solve when its residual exceeds sqrt(chi2) * outlier_sigma pixels (0.5: a stereo
  /// point 1.4 px off). ORB-SLAM's gates are 1 px; at 1 px, neighbouring-corner and line
  /// misassociations of 1-3 px stayed in the map. The Huber thresholds stay at 1 px.
  double outlier_sigma = 0.5;
  double point_chi2_mono = 5.991;    ///< outlier above this squared whitened residual, 2 dof (95 %)
  double point_chi2_stereo = 7.815;  ///< same, 3 dof
  double line_chi2_mono = 5.991;     ///< lines, 2 dof
  double line_chi2_stereo = 9.488;   ///< lines, 4 dof
  double min_depth = 0.05;           ///< observations whose point is closer (m) are outliers
  /// Standard deviation (pixels at any octave) of a stereo point's disparity, fitted then as
  /// a residual of its own (DisparityCost) next to the left-image position, with its own Huber
  /// loss and outlier gate (chi2, 1 dof, in units of outlier_sigma): a disparity outlier leaves
  /// the second pass, the left-image observation stays. The stereo matcher refines the
  /// disparity at full resolution on its own, so the right column is not a second independent
  /// measurement of the left one's position. 1 = the left image's standard deviation at octave
  /// 0. 0 = the right-image column is fitted as a third residual of the point, with the left
  /// image's standard deviation (corridor 2.4 mm, KITTI clip 0.509 m against 1.5 mm and 0.495 m
  /// with the default and mapping.align_points; docs/BENCHMARKS.md, design decisions).
  double disparity_sigma = 1.0;
  /// Weight (per metre) of LineExtentCost, which holds each line landmark's endpoints where
  /// they are along the line (the observations do not constrain that direction); 0 = off.
  double line_extent_weight = 5.0;
  /// Line residual: "projected" (distances of the projected 3D endpoints to the observed line,
  /// the paper's eq. 6, LineCost), "observed" (distances of the observed segment's endpoints to
  /// the projected 3D line, EndpointLineCost), or "auto": observed in lines-only tracking,
  /// projected otherwise (SlamSystem resolves it; here auto means projected): with lines
  /// alone the observed form measured better on every benchmark sequence.
  std::string line_residual = "auto";
  int num_threads = 1;  ///< Ceres threads (tracking keeps the other core)
  /// Schur complement solver for the reduced camera system: "sparse" (SuiteSparse Cholesky)
  /// or "dense" (Eigen; can be faster for the few tens of keyframes of a local window).
  std::string schur = "sparse";
  /// Empty when valid, else "key=value must be ..." naming the first bad key.
  std::string Validate() const;
};

/// A keyframe pose in the problem.
struct BaPose {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  SE3 T_w_c;           ///< in: initial value; out: optimised (unchanged when fixed)
  bool fixed = false;  ///< held constant (keyframes outside the local window, the gauge)
};

/// An observation of point landmark `point` in keyframe `pose`.
struct BaPointObservation {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  int pose = 0;
  int point = 0;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  ///< left-image pixel
  bool stereo = false;                           ///< u_right is measured (stereo match)
  double u_right = 0.0;                          ///< right-image column when stereo
  double sqrt_info = 1.0;  ///< 1 / sigma in pixels (sigma grows with the pyramid octave)
};

/// An observation of line landmark `line` in keyframe `pose`.
struct BaLineObservation {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  int pose = 0;
  int line = 0;
  /// Observed segment: endpoints in the left image, and (stereo) their right-image matches.
  Eigen::Vector2d s = Eigen::Vector2d::Zero(), e = Eigen::Vector2d::Zero();
  bool stereo = false;  ///< s_right, e_right are measured
  Eigen::Vector2d s_right = Eigen::Vector2d::Zero(), e_right = Eigen::Vector2d::Zero();
  double sqrt_info = 1.0;
};

/// A bundle adjustment problem: poses, landmarks and observations referring to them by index.
struct BaProblem {
  std::vector<BaPose, Eigen::aligned_allocator<BaPose>> poses;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points;  ///< p_w
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> line_P;  ///< P_w
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> line_Q;  ///< Q_w
  std::vector<BaPointObservation, Eigen::aligned_allocator<BaPointObservation>> point_obs;
  std::vector<BaLineObservation, Eigen::aligned_allocator<BaLineObservation>> line_obs;
};

/// What the optimisation did.
struct BaSummary {
  bool success = false;                         ///< Ceres reported a usable solution
  std::string message;                          ///< Ceres' report when not successful
  int iterations = 0;                           ///< both passes together
  double initial_cost = 0.0, final_cost = 0.0;  ///< of the first / last pass
  std::vector<uint8_t> point_outlier;  ///< per point observation: 1 = outlier after the solve
  std::vector<uint8_t> line_outlier;   ///< per line observation
  int point_outliers = 0, line_outliers = 0;
  double solve_ms = 0.0;
};

/// Optimises `problem` in place (poses not fixed, every landmark). At least one pose must be
/// fixed (the gauge); when none is, the first is held fixed. Throws ConfigError on invalid
/// options; bad indices in observations are skipped. When `abort` is given and becomes true,
/// the solve stops after the current iteration and reports no success ("aborted"), leaving
/// `problem` unchanged.
BaSummary SolveBundleAdjustment(const StereoCamera& camera, const BundleAdjustmentOptions& options,
                                BaProblem* problem, const std::atomic<bool>* abort = nullptr);

}  // namespace pl_slam
