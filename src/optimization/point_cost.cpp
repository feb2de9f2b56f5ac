#include "pl_slam/optimization/point_cost.h"

#include "pl_slam/geometry/se3.h"
#include "pl_slam/optimization/se3_manifold.h"

namespace pl_slam {

template <int kResiduals>
bool PointCost<kResiduals>::Evaluate(double const* const* parameters, double* residuals,
                                     double** jacobians) const {
  const SE3 T_c_w = SE3FromParams(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> p_w(parameters[1]);
  const Eigen::Vector3d X = T_c_w * p_w;
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> r(residuals);
  if (!(X.z() > min_depth_)) {
    r.setZero();
    if (jacobians) {
      if (jacobians[0])
        Eigen::Map<Eigen::Matrix<double, kResiduals, 7, Eigen::RowMajor>>(jacobians[0]).setZero();
      if (jacobians[1])
        Eigen::Map<Eigen::Matrix<double, kResiduals, 3, Eigen::RowMajor>>(jacobians[1]).setZero();
    }
    return true;
  }
  const double iz = 1.0 / X.z();
  const double fx = camera_.fx, fy = camera_.fy;
  r(0) = sqrt_info_ * (fx * X.x() * iz + camera_.cx - uv_.x());
  r(1) = sqrt_info_ * (fy * X.y() * iz + camera_.cy - uv_.y());
  if constexpr (kResiduals == 3)
    r(2) =
        sqrt_info_ * (fx * (X.x() - camera_.baseline) * iz + camera_.cx + camera_.doffs - u_right_);
  if (!jacobians) return true;
  // d(residual)/dX, X the point in the camera frame.
  Eigen::Matrix<double, kResiduals, 3> J_X;
  J_X.setZero();
  J_X(0, 0) = fx * iz;
  J_X(0, 2) = -fx * X.x() * iz * iz;
  J_X(1, 1) = fy * iz;
  J_X(1, 2) = -fy * X.y() * iz * iz;
  if constexpr (kResiduals == 3) {
    J_X(2, 0) = fx * iz;
    J_X(2, 2) = -fx * (X.x() - camera_.baseline) * iz * iz;
  }
  J_X *= sqrt_info_;
  if (jacobians[0]) {
    // Left perturbation: X <- Exp(d) X ~ X + rho + phi x X, dX/dd = [I, -[X]x].
    Eigen::Map<Eigen::Matrix<double, kResiduals, 7, Eigen::RowMajor>> J(jacobians[0]);
    J.template leftCols<3>() = J_X;
    J.template middleCols<3>(3) = -J_X * Hat(X);
    J.col(6).setZero();
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, kResiduals, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = J_X * T_c_w.rotation();
  }
  return true;
}

bool DisparityCost::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const SE3 T_c_w = SE3FromParams(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> p_w(parameters[1]);
  const Eigen::Vector3d X = T_c_w * p_w;
  if (!(X.z() > min_depth_)) {
    residuals[0] = 0.0;
    if (jacobians) {
      if (jacobians[0]) Eigen::Map<Eigen::Matrix<double, 1, 7>>(jacobians[0]).setZero();
      if (jacobians[1]) Eigen::Map<Eigen::Matrix<double, 1, 3>>(jacobians[1]).setZero();
    }
    return true;
  }
  const double iz = 1.0 / X.z();
  const double fb = camera_.fx * camera_.baseline;
  residuals[0] = sqrt_info_ * (fb * iz - camera_.doffs - disparity_);
  if (!jacobians) return true;
  const Eigen::RowVector3d J_X(0.0, 0.0, -sqrt_info_ * fb * iz * iz);
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 1, 7>> J(jacobians[0]);
    J.leftCols<3>() = J_X;
    J.middleCols<3>(3) = -J_X * Hat(X);
    J(6) = 0.0;
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 1, 3>> J(jacobians[1]);
    J = J_X * T_c_w.rotation();
  }
  return true;
}

template class PointCost<2>;
template class PointCost<3>;

}  // namespace pl_slam
