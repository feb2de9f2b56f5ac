// Line-segment residual of bundle adjustment (paper eqs. 5-6), with analytic Jacobians.
#pragma once

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pl_slam/camera/stereo_camera.h"

namespace pl_slam {

/// Residual: signed pixel distances of the projected 3D endpoints P_w, Q_w to the observed
/// infinite line l (l . (u, v, 1), l(0)^2 + l(1)^2 = 1) in the left image, scaled by
/// sqrt_info; the stereo form adds the distances to the observed right-image line l_right.
/// Parameter blocks: T_c_w (7, lifted left-perturbation Jacobian, see se3_manifold.h) and the
/// landmark [P_w; Q_w] (6: one block, so that landmarks stay independent for Schur elimination).
/// Endpoints below min_depth give zero residuals and Jacobians. The endpoints may slide along the
/// 3D line without changing the residual; Levenberg-Marquardt's damping keeps that direction fixed
/// in practice.
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

/// The normalised infinite line through two pixels, scaled so l(0)^2 + l(1)^2 = 1; zero when
/// the pixels coincide.
Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b);

}  // namespace pl_slam
