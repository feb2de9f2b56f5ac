// Point reprojection residual of bundle adjustment (paper eq. 4), with analytic Jacobians.
#pragma once

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "pl_slam/camera/stereo_camera.h"

namespace pl_slam {

/// Residual sqrt_info * (pi(T_c_w * p_w) - uv) in the left image, plus, for a stereo
/// observation, sqrt_info * (u_right(T_c_w * p_w) - u_right_observed): the right image's column
/// constrains depth (what the stereo match measured). Parameter blocks: T_c_w (7, see
/// se3_manifold.h: lifted left-perturbation Jacobian) and p_w (3). A point at depth below
/// min_depth contributes a zero residual and zero Jacobians (the caller drops it afterwards).
template <int kResiduals>
class PointCost final : public ceres::SizedCostFunction<kResiduals, 7, 3> {
  static_assert(kResiduals == 2 || kResiduals == 3, "2 (left image) or 3 (stereo) residuals");

 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  /// `u_right` is ignored for the 2-residual (monocular) form.
  PointCost(const StereoCamera& camera, const Eigen::Vector2d& uv, double u_right, double sqrt_info,
            double min_depth = 1e-3)
      : camera_(camera), uv_(uv), u_right_(u_right), sqrt_info_(sqrt_info), min_depth_(min_depth) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  Eigen::Vector2d uv_;
  double u_right_;
  double sqrt_info_;
  double min_depth_;
};

/// Disparity residual of a stereo point observed at `disparity` (left column minus right):
/// sqrt_info * (fx * baseline / z - doffs - disparity), z the point's depth in T_c_w. The
/// stereo matcher refines a disparity on its own (matching/point_matching.h), so it is a
/// measurement of its own, with its own noise and outliers, next to MonoPointCost's left-image
/// position. Parameter blocks as PointCost's; below min_depth zero residual and Jacobians.
class DisparityCost final : public ceres::SizedCostFunction<1, 7, 3> {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  DisparityCost(const StereoCamera& camera, double disparity, double sqrt_info,
                double min_depth = 1e-3)
      : camera_(camera), disparity_(disparity), sqrt_info_(sqrt_info), min_depth_(min_depth) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  double disparity_;
  double sqrt_info_;
  double min_depth_;
};

using MonoPointCost = PointCost<2>;
using StereoPointCost = PointCost<3>;

extern template class PointCost<2>;
extern template class PointCost<3>;

}  // namespace pl_slam
