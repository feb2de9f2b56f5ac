// SE(3) pose parameter blocks for Ceres.
//
// A pose block holds T (e.g. T_c_w) as 7 doubles [qx qy qz qw tx ty tz] and is updated on the
// LEFT, T <- Exp(delta) * T with delta = [rho; phi] (the project's tangent order), so the
// analytic Jacobians of the residuals are the same left-perturbation Jacobians the tracker
// uses. Convention ("lifted" Jacobians): a cost function returns dr/d(delta) in the first six
// columns of its 7-column Jacobian block and zeros in the last one; the manifold's
// PlusJacobian is [I6; 0], so Ceres' tangent Jacobian J * PlusJacobian is exactly dr/d(delta).
#pragma once

#include <ceres/manifold.h>

#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Writes T as [qx qy qz qw tx ty tz].
void SE3ToParams(const SE3& T, double* params);
/// Reads [qx qy qz qw tx ty tz] (the quaternion is normalised).
SE3 SE3FromParams(const double* params);

/// The SE(3) manifold described at the top of this file.
class SE3Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  /// x_plus_delta = Exp(delta) * x.
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  /// [I6; 0] (lifted convention, see the file comment).
  bool PlusJacobian(const double* x, double* jacobian) const override;
  /// y_minus_x = Log(y * x^-1), so that Plus(x, Minus(y, x)) = y.
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  /// [I6 0] (lifted convention).
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace pl_slam
