// Robust frame-to-frame motion estimation from point and line-segment correspondences (paper
// Section IV-C): previous-frame 3D features against current-frame 2D observations, robust
// Gauss-Newton with a Pseudo-Huber loss, two steps (optimise, drop outliers, re-optimise), and
// the covariance of the result.
//
// Conventions (read these before using the covariances):
//  - The estimate is T_cur_prev: it maps points of the previous left camera frame into the
//    current left camera frame, X_cur = T_cur_prev * P_prev.
//  - Perturbations are on the LEFT, tangent order [rho; phi] (translation; rotation) as in se3.h:
//    T_cur_prev_true = Exp(d) * T_cur_prev_est with d ~ N(0, covariance).
//  - covariance_prev_cur is the covariance of the inverse, T_prev_cur = T_cur_prev^-1, again for
//    a LEFT perturbation: T_prev_cur_true = Exp(e) * T_prev_cur_est with e ~ N(0,
//    covariance_prev_cur). It equals Ad(T_prev_cur) * covariance * Ad(T_prev_cur)^T. This is the
//    one to feed to the keyframe selector, which chains T_kf_cur = T_kf_prev * T_prev_cur.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// A previous-frame 3D point observed at a current-frame left-image pixel.
struct PointMatch3D2D {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector3d P_prev = Eigen::Vector3d::Zero();  ///< 3D point, previous left camera frame
  Eigen::Vector2d uv_cur = Eigen::Vector2d::Zero();  ///< observation, current left image, pixels
  /// Relative information of the observation, (sigma_nominal / sigma_i)^2, e.g. 1 / scale^(2
  /// octave): the residual is scaled by sqrt(weight) before the loss and the outlier test, so
  /// thresholds stay in "nominal pixels". Must be finite and > 0 (else the match is ignored).
  double weight = 1.0;
  /// Depth noise of P_prev: the standard deviation of the disparity it was triangulated from,
  /// relative to the residual's own noise at zero motion. 0 (the default) takes the depth as
  /// exact (landmarks refined over many views); 1 suits a one-frame stereo point (disparity and
  /// residual are both the difference of two pixel measurements). When > 0, the residual is
  /// whitened along the direction a depth error moves the projection under T, so that under
  /// forward motion the points far from the image centre, whose projection a depth error
  /// shifts most, weigh less; at zero motion it changes nothing. Must be finite and >= 0 (else
  /// the match is ignored).
  double depth_noise = 0.0;
  /// The point's column in the current right image (stereo), NaN when it has none. Used with
  /// MotionEstimatorOptions::stereo_residual.
  double u_right_cur = std::numeric_limits<double>::quiet_NaN();
};

/// A previous-frame 3D segment (endpoints P, Q) observed as a current-frame infinite line.
struct LineMatch3D2D {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector3d P_prev = Eigen::Vector3d::Zero();  ///< 3D start point, previous left camera
  Eigen::Vector3d Q_prev = Eigen::Vector3d::Zero();  ///< 3D end point, previous left camera
  /// Observed line in the current left image, l . (u, v, 1) = 0. Normalised internally so that
  /// l(0)^2 + l(1)^2 = 1 (LineFeature::l already is); a line with l(0) = l(1) = 0 is ignored.
  Eigen::Vector3d l_cur = Eigen::Vector3d::Zero();
  double weight = 1.0;  ///< relative information, as PointMatch3D2D::weight
  /// Depth noise of both endpoints, as PointMatch3D2D::depth_noise (the distance of each
  /// projected endpoint to the line is whitened); 1 / |sin| of the segment's angle to the image
  /// rows for a stereo segment, whose endpoint disparities come from crossing the rows.
  double depth_noise = 0.0;
};

/// Point correspondences in an aligned container (fixed-size Eigen members).
using PointMatches3D2D = std::vector<PointMatch3D2D, Eigen::aligned_allocator<PointMatch3D2D>>;
/// Line correspondences in an aligned container (fixed-size Eigen members).
using LineMatches3D2D = std::vector<LineMatch3D2D, Eigen::aligned_allocator<LineMatch3D2D>>;

/// Options of EstimateMotion. Residual norms below are sqrt(weight) * |r| in pixels.
struct MotionEstimatorOptions {
  int max_iterations = 20;  ///< Gauss-Newton iterations per step (there are two steps)
  /// Pseudo-Huber scale, pixels: quadratic below, linear above. About 1.5 x a 0.5-1 px feature
  /// noise keeps ~90 % efficiency on clean data while bounding each outlier's pull.
  double huber_delta_px = 1.0;
  /// Outlier when s > outlier_chi2 * sigma_robust^2, s the squared residual norm (2 dof for both
  /// points and lines) and sigma_robust from the median of s. 9.21 = chi2(2) at 99 %.
  double outlier_chi2 = 9.21;
  double outlier_min_px = 2.0;   ///< the outlier threshold never drops below this (clean data)
  double outlier_max_px = 10.0;  ///< nor exceeds this (a poor first step must not keep everything)
  double min_update = 1e-9;      ///< converged when |delta| (metres and radians) is below this
  double min_relative_cost_change = 1e-10;  ///< converged when the cost drops by less than this
  double min_depth = 0.05;  ///< residuals whose transformed depth (metres) is below are skipped
  int min_inliers = 6;      ///< fewer point + line inliers after the second step is a failure
  /// Smallest eigenvalue of the Jacobi-normalised Hessian (unit diagonal) below which the motion
  /// is reported unobservable. Exact degeneracies (e.g. noise-free, mutually parallel lines
  /// only) sit at ~1e-16; noise lifts them to ~1e-3, where the estimate succeeds and the
  /// covariance shows the weak direction instead (tens of cm). Well-posed sets: 1e-5 (4
  /// lines) to 0.1 (hundreds of points).
  double rank_tolerance = 1e-9;
  /// Floor on the residual standard deviation (pixels) that scales the covariance, so
  /// noise-free input does not produce a zero (singular) covariance.
  double min_sigma_px = 0.05;
  bool use_points = true;  ///< use the point correspondences
  bool use_lines = true;   ///< use the line correspondences
  /// Estimate the rotation only: the current camera centre stays where the prior puts it and
  /// the orientation about it is fitted (3 unknowns; the covariance's translation block is
  /// zero). For frames too poor for a full estimate, whose position a motion model gives.
  bool rotation_only = false;
  /// Points with a current right-image column (PointMatch3D2D::u_right_cur) are also fitted
  /// there, as a third residual (ORB-SLAM2's stereo reprojection): the current frame's
  /// disparity measures the distance along the view, which the left image measures only
  /// through the features' spread. The outlier test divides such a point's squared residual
  /// by 3/2 (3 dof against 2).
  bool stereo_residual = false;
  /// With a prior covariance (EstimateMotion): the correspondences' noise is taken as at least
  /// this (pixels) when weighed against the prior and in the covariance. A few features' own
  /// scatter understates their error (a detector's view-dependent offsets move them together),
  /// and a prior they overrule on that understatement no longer holds what they leave open.
  double prior_min_sigma_px = 1.0;

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// Result of EstimateMotion. On failure (success == false) T_cur_prev is the prior, both
/// covariances are zero (meaningless; a selector must not read them as certainty), the inlier
/// flags are all 0 and `failure` says why.
struct MotionEstimate {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  SE3 T_cur_prev;  ///< maps previous-camera points to current-camera points
  /// Covariance of a left perturbation of T_cur_prev, [rho; phi] order: sigma^2 * H^-1 with
  /// H = sum rho'(s_i) w_i J_i^T J_i the robust Gauss-Newton Hessian of the second step at the
  /// solution (paper: "inverse of the Hessian in the last iteration") and sigma^2 the
  /// robust residual variance sigma_px^2 below.
  Matrix6d covariance = Matrix6d::Zero();
  /// Covariance of a left perturbation of T_prev_cur = T_cur_prev^-1:
  /// Ad(T_prev_cur) * covariance * Ad(T_prev_cur)^T.
  Matrix6d covariance_prev_cur = Matrix6d::Zero();
  std::vector<uint8_t> point_inlier;  ///< 1 when used in the final (second) step, per point
  std::vector<uint8_t> line_inlier;   ///< 1 when used in the final (second) step, per line
  int point_inliers = 0;              ///< number of 1s in point_inlier
  int line_inliers = 0;               ///< number of 1s in line_inlier
  int iterations = 0;                 ///< Gauss-Newton iterations, both steps together
  /// RMS of the scalar inlier residuals sqrt(w) * r at the solution, pixels.
  double rmse_px = 0.0;
  /// Residual standard deviation that scales the covariance, pixels, with Huber's correction
  /// for the robust loss: sigma^2 = [sum rho'_i^2 s_i / (m - 6)] * c1 / c2^2 / k over the m
  /// scalar inlier residuals, c1 = mean rho'_i, c2 = mean (rho'_i + rho'_i^3) / 2, k the share
  /// of a chi2(2) variance kept below the outlier threshold (see the .cpp). On clean data it
  /// is the least-squares sqrt(sum s_i / (m - 6)). Floored at options.min_sigma_px.
  double sigma_px = 0.0;
  bool success = false;  ///< false: see `failure`
  std::string failure;   ///< why the estimate failed; empty on success
};

/// True when the largest standard deviation of a [rho; phi] covariance is at most max_m in
/// translation and max_rad in rotation (a zero covariance, i.e. a failed estimate, passes:
/// callers check success first).
bool SigmaWithin(const Matrix6d& covariance, double max_m, double max_rad);

/// Point residual r = pi(T P) - uv (pixels) and, when J is not null, its Jacobian dr/dd for the
/// left perturbation T <- Exp(d) * T, d = [rho; phi]. Returns false and leaves r and J untouched
/// when the transformed point's depth is not above min_depth (behind the camera, or NaN).
bool PointResidualAndJacobian(const StereoCamera& cam, const SE3& T_cur_prev,
                              const Eigen::Vector3d& P_prev, const Eigen::Vector2d& uv_cur,
                              double min_depth, Eigen::Vector2d* r, Eigen::Matrix<double, 2, 6>* J);

/// Line residual r = [l . (pi(T P), 1); l . (pi(T Q), 1)] (signed pixel distances of the two
/// projected endpoints to the observed line; l must be normalised, l(0)^2 + l(1)^2 = 1) and,
/// when J is not null, its Jacobian dr/dd for T <- Exp(d) * T. Returns false and leaves r and J
/// untouched when either transformed endpoint's depth is not above min_depth.
bool LineResidualAndJacobian(const StereoCamera& cam, const SE3& T_cur_prev,
                             const Eigen::Vector3d& P_prev, const Eigen::Vector3d& Q_prev,
                             const Eigen::Vector3d& l_cur, double min_depth, Eigen::Vector2d* r,
                             Eigen::Matrix<double, 2, 6>* J);

/// Pseudo-Huber loss of a squared residual norm s: 2 delta^2 (sqrt(1 + s / delta^2) - 1).
double PseudoHuberLoss(double s, double delta);
/// Its derivative d rho / d s = 1 / sqrt(1 + s / delta^2): the IRLS weight.
double PseudoHuberWeight(double s, double delta);

/// Estimates T_cur_prev from the matches, starting at prior_T_cur_prev (e.g. constant
/// velocity): LM-damped robust Gauss-Newton, then outlier removal, then a second optimisation
/// over the inliers. Never returns NaN; degenerate input (too few correspondences, unobservable
/// motion, non-finite prior) is reported through success / failure. Throws ConfigError when
/// options.Validate() fails. The camera's fx, fy, cx, cy must be valid (unchecked).
///
/// `prior_covariance` (optional; [rho; phi], left perturbation of prior_T_cur_prev, symmetric
/// positive definite): the prior is then also a Gaussian measurement of the motion (a motion
/// model's prediction with its uncertainty), which holds what the correspondences leave
/// unobservable (a few clustered features trade rotation against translation): no direction
/// is rank-deficient, and the covariance combines both. Prior and correspondences are weighed
/// by their noise, the correspondences' robust residual variance floored at
/// options.prior_min_sigma_px. Not with rotation_only.
MotionEstimate EstimateMotion(const StereoCamera& cam, const PointMatches3D2D& points,
                              const LineMatches3D2D& lines, const SE3& prior_T_cur_prev,
                              const MotionEstimatorOptions& options,
                              const Matrix6d* prior_covariance = nullptr);

}  // namespace pl_slam
