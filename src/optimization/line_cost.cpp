#include "pl_slam/optimization/line_cost.h"

#include "pl_slam/geometry/se3.h"
#include "pl_slam/optimization/se3_manifold.h"

namespace pl_slam {

Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d l =
      Eigen::Vector3d(a.x(), a.y(), 1.0).cross(Eigen::Vector3d(b.x(), b.y(), 1.0));
  const double n = l.head<2>().norm();
  return n > 0.0 ? Eigen::Vector3d(l / n) : Eigen::Vector3d::Zero();
}

template <int kResiduals>
bool LineCost<kResiduals>::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const SE3 T_c_w = SE3FromParams(parameters[0]);
  const Eigen::Matrix3d R = T_c_w.rotation();
  const Eigen::Vector3d X[2] = {T_c_w * Eigen::Map<const Eigen::Vector3d>(parameters[1]),
                                T_c_w * Eigen::Map<const Eigen::Vector3d>(parameters[1] + 3)};
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> r(residuals);
  using JPose = Eigen::Map<Eigen::Matrix<double, kResiduals, 7, Eigen::RowMajor>>;
  using JLine = Eigen::Map<Eigen::Matrix<double, kResiduals, 6, Eigen::RowMajor>>;
  if (!(X[0].z() > min_depth_ && X[1].z() > min_depth_)) {
    r.setZero();
    if (jacobians) {
      if (jacobians[0]) Eigen::Map<Eigen::VectorXd>(jacobians[0], kResiduals * 7).setZero();
      if (jacobians[1]) Eigen::Map<Eigen::VectorXd>(jacobians[1], kResiduals * 6).setZero();
    }
    return true;
  }
  const double fx = camera_.fx, fy = camera_.fy;
  // Rows: left line at P, left line at Q, then (stereo) right line at P, right line at Q.
  Eigen::Matrix<double, kResiduals, 3> J_X[2];
  J_X[0].setZero();
  J_X[1].setZero();
  const int views = kResiduals / 2;
  for (int view = 0; view < views; ++view) {
    const Eigen::Vector3d& l = view == 0 ? l_ : l_right_;
    const double shift = view == 0 ? 0.0 : camera_.baseline;
    for (int k = 0; k < 2; ++k) {
      const double iz = 1.0 / X[k].z();
      const double u = fx * (X[k].x() - shift) * iz + camera_.cx;
      const double v = fy * X[k].y() * iz + camera_.cy;
      const int row = 2 * view + k;
      r(row) = sqrt_info_ * (l.x() * u + l.y() * v + l.z());
      // d(l . (u, v, 1)) / dX.
      J_X[k](row, 0) = sqrt_info_ * l.x() * fx * iz;
      J_X[k](row, 1) = sqrt_info_ * l.y() * fy * iz;
      J_X[k](row, 2) =
          -sqrt_info_ * (l.x() * fx * (X[k].x() - shift) + l.y() * fy * X[k].y()) * iz * iz;
    }
  }
  if (!jacobians) return true;
  if (jacobians[0]) {
    JPose J(jacobians[0]);
    J.setZero();
    for (int k = 0; k < 2; ++k) {
      J.template leftCols<3>() += J_X[k];
      J.template middleCols<3>(3) += -J_X[k] * Hat(X[k]);
    }
  }
  if (jacobians[1]) {
    JLine J(jacobians[1]);
    J.template leftCols<3>() = J_X[0] * R;
    J.template rightCols<3>() = J_X[1] * R;
  }
  return true;
}

template class LineCost<2>;
template class LineCost<4>;

}  // namespace pl_slam
