#include "pl_slam/geometry/se3.h"

#include <cmath>

namespace pl_slam {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = Hat(phi);
  if (theta2 < 1e-12) {
    // Second-order Taylor expansion keeps the result orthonormal to machine precision.
    return Eigen::Matrix3d::Identity() + K + 0.5 * K * K;
  }
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() + (std::sin(theta) / theta) * K +
         ((1.0 - std::cos(theta)) / theta2) * K * K;
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  // Going through the quaternion is stable over the whole range including theta ~ pi.
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-10) return 2.0 * v / q.w();
  const double theta = 2.0 * std::atan2(s, q.w());
  return theta * v / s;
}

Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = Hat(phi);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * K + K * K / 6.0;
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() + ((1.0 - std::cos(theta)) / theta2) * K +
         ((theta - std::sin(theta)) / (theta2 * theta)) * K * K;
}

Eigen::Matrix3d LeftJacobianInvSO3(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const Eigen::Matrix3d K = Hat(phi);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() - 0.5 * K + K * K / 12.0;
  const double theta = std::sqrt(theta2);
  const double coeff = 1.0 / theta2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  return Eigen::Matrix3d::Identity() - 0.5 * K + coeff * K * K;
}

SE3 SE3::FromMatrix(const Eigen::Matrix4d& T) {
  return SE3(Eigen::Matrix3d(T.block<3, 3>(0, 0)), Eigen::Vector3d(T.block<3, 1>(0, 3)));
}

SE3 SE3::Exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  return SE3(ExpSO3(phi), LeftJacobianSO3(phi) * rho);
}

Vector6d SE3::Log() const {
  Vector6d xi;
  const Eigen::Vector3d phi = LogSO3(rotation());
  xi.head<3>() = LeftJacobianInvSO3(phi) * t_;
  xi.tail<3>() = phi;
  return xi;
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.block<3, 3>(0, 0) = rotation();
  T.block<3, 1>(0, 3) = t_;
  return T;
}

Eigen::Matrix<double, 3, 4> SE3::matrix3x4() const { return matrix().topRows<3>(); }

SE3 SE3::inverse() const {
  const Eigen::Quaterniond qi = q_.conjugate();
  return SE3(qi, -(qi * t_));
}

Matrix6d SE3::Adjoint() const {
  Matrix6d A = Matrix6d::Zero();
  const Eigen::Matrix3d R = rotation();
  A.block<3, 3>(0, 0) = R;
  A.block<3, 3>(0, 3) = Hat(t_) * R;
  A.block<3, 3>(3, 3) = R;
  return A;
}

double SE3::RotationAngle() const { return LogSO3(rotation()).norm(); }

bool SE3::IsFinite() const { return q_.coeffs().allFinite() && t_.allFinite(); }

}  // namespace pl_slam
