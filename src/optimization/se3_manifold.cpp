#include "pl_slam/optimization/se3_manifold.h"

#include <Eigen/Core>

namespace pl_slam {

void SE3ToParams(const SE3& T, double* params) {
  const Eigen::Quaterniond& q = T.so3();
  params[0] = q.x();
  params[1] = q.y();
  params[2] = q.z();
  params[3] = q.w();
  params[4] = T.translation().x();
  params[5] = T.translation().y();
  params[6] = T.translation().z();
}

SE3 SE3FromParams(const double* params) {
  return SE3(Eigen::Quaterniond(params[3], params[0], params[1], params[2]),
             Eigen::Vector3d(params[4], params[5], params[6]));
}

bool SE3Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Vector6d> d(delta);
  SE3ToParams(SE3::Exp(d) * SE3FromParams(x), x_plus_delta);
  return true;
}

bool SE3Manifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<6>().setIdentity();
  return true;
}

bool SE3Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<Vector6d> out(y_minus_x);
  out = (SE3FromParams(y) * SE3FromParams(x).inverse()).Log();
  return true;
}

bool SE3Manifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

}  // namespace pl_slam
