// Line-segment residual of bundle adjustment (paper eqs. 5-6), with analytic Jacobians.
#pragma once

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Residual: signed pixel distances of the projected 3D endpoints P_w, Q_w to the observed
/// infinite line l (l . (u, v, 1), l(0)^2 + l(1)^2 = 1) in the left image, scaled by
/// sqrt_info; the stereo form adds the distances to the observed right-image line l_right.
/// Parameter blocks: T_c_w (7, lifted left-perturbation Jacobian, see se3_manifold.h) and the
/// landmark [P_w; Q_w] (6: one block, so that landmarks stay independent for Schur elimination).
/// Endpoints below min_depth give zero residuals and Jacobians. The endpoints may slide along the
/// 3D line without changing the residual: bundle adjustment adds a LineExtentCost per landmark
/// and local mapping re-anchors the extent afterwards (without them, 70-80% of the room's line
/// landmarks collapsed to P = Q within a few keyframes).
template <int kResiduals>
class LineCost final : public ceres::SizedCostFunction<kResiduals, 7, 6> {
  static_assert(kResiduals == 2 || kResiduals == 4, "2 (left image) or 4 (stereo) residuals");

 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  /// `l_right` is ignored for the 2-residual (monocular) form. Both lines must be normalised.
  LineCost(const StereoCamera& camera, const Eigen::Vector3d& l, const Eigen::Vector3d& l_right,
           double sqrt_info, double min_depth = 1e-3)
      : camera_(camera), l_(l), l_right_(l_right), sqrt_info_(sqrt_info), min_depth_(min_depth) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  Eigen::Vector3d l_, l_right_;
  double sqrt_info_;
  double min_depth_;
};

using MonoLineCost = LineCost<2>;
using StereoLineCost = LineCost<4>;

extern template class LineCost<2>;
extern template class LineCost<4>;

/// The other form of the line residual: signed pixel distances of the OBSERVED segment's
/// endpoints (s, e) to the projection of the landmark's infinite 3D line, scaled by sqrt_info;
/// the stereo form adds the right image (s_right, e_right: the right-image points of the
/// stereo-matched segment's endpoints). Unlike LineCost it does not depend on where the landmark's
/// endpoints lie along their line, so an observation whose view covers another part of a long
/// line (a corridor wall passing by) keeps its weight, and an endpoint near or behind the camera
/// neither drops the observation nor gives it the leverage of a near point. The projected line
/// is the plane through the camera centre and both endpoints, m = P_c x Q_c, which stays valid
/// when one endpoint is behind the camera. Gives zero residuals and Jacobians when both endpoints
/// are closer than min_depth or the line passes through the camera centre.
/// Parameter blocks as LineCost.
template <int kResiduals>
class EndpointLineCost final : public ceres::SizedCostFunction<kResiduals, 7, 6> {
  static_assert(kResiduals == 2 || kResiduals == 4, "2 (left image) or 4 (stereo) residuals");

 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  /// `s_right` and `e_right` are ignored for the 2-residual (monocular) form.
  EndpointLineCost(const StereoCamera& camera, const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                   const Eigen::Vector2d& s_right, const Eigen::Vector2d& e_right, double sqrt_info,
                   double min_depth = 1e-3)
      : camera_(camera),
        obs_{s, e, s_right, e_right},
        sqrt_info_(sqrt_info),
        min_depth_(min_depth) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  Eigen::Vector2d obs_[4];  // left s, e, right s, e
  double sqrt_info_;
  double min_depth_;
};

using MonoEndpointLineCost = EndpointLineCost<2>;
using StereoEndpointLineCost = EndpointLineCost<4>;

extern template class EndpointLineCost<2>;
extern template class EndpointLineCost<4>;

/// Signed pixel distance of pixel `px` to the image of the 3D line through P_c and Q_c (camera
/// frame of a camera with focal lengths fx, fy and principal point cx, cy), and its gradient
/// with respect to m = P_c x Q_c in `d_m` (may be null). Zero when m has no image direction.
double PixelToProjectedLine(const Eigen::Vector3d& m, const Eigen::Vector2d& px, double fx,
                            double fy, double cx, double cy, Eigen::Vector3d* d_m);

/// Gauge of a line landmark's extent: residuals w * d . (P - P0) and w * d . (Q - Q0), where
/// d is the unit direction of (Q0 - P0). Only the endpoints' positions ALONG the line are held
/// (to where the observations put them); across the line they stay free, so the observations
/// alone decide where the line is. `weight` is per metre (w = 5: a 20 cm slide costs as much
/// as a one-sigma reprojection error; weak, because the extent is re-anchored after every BA
/// anyway, see AnchorSegmentToObservation; 50 made the low-texture corridor 3x less accurate).
/// Degenerate P0 = Q0 gives zero residuals and Jacobians.
class LineExtentCost final : public ceres::SizedCostFunction<2, 6> {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  LineExtentCost(const Eigen::Vector3d& P0, const Eigen::Vector3d& Q0, double weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d P0_, Q0_, d_;  // d_ = weight * unit direction (zero when degenerate)
};

/// Re-anchors a line landmark's extent to one observation of it: replaces P_w and Q_w by the
/// points of their infinite 3D line closest to the viewing rays of the observed segment's
/// endpoints `s` and `e` (left-image pixels of a camera at T_w_c). Bundle adjustment fixes
/// where the line is, not where the segment ends: its endpoint residuals all pull each endpoint
/// to the same best point of the line, and repeated local BAs shrink segments toward it even
/// with LineExtentCost. Returns false (and changes nothing) when the line is degenerate, a ray
/// is within 2 degrees of parallel to it, or the result is shorter than 1 cm or behind the
/// camera.
bool AnchorSegmentToObservation(const StereoCamera& camera, const SE3& T_w_c,
                                const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                Eigen::Vector3d* P_w, Eigen::Vector3d* Q_w);

/// The normalised infinite line through two pixels, scaled so l(0)^2 + l(1)^2 = 1; zero when
/// the pixels coincide.
Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b);

}  // namespace pl_slam
