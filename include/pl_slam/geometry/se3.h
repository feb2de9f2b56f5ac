// Rigid-body transforms (SE(3)) and rotation helpers (SO(3)).
//
// Naming convention (house style): T_a_b is the pose of frame b expressed in frame a, so
// that T_a_b * p_b = p_a and T_a_b * T_b_c = T_a_c. Tangent vectors are ordered
// [translation; rotation] (rho, phi) everywhere in the project.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pl_slam {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix such that Hat(a) * b = a x b.
Eigen::Matrix3d Hat(const Eigen::Vector3d& v);

/// SO(3) exponential map of a rotation vector (axis * angle), stable near zero.
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi);

/// SO(3) logarithm: rotation vector of R, stable near 0 and near pi.
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R);

/// Left Jacobian of SO(3) at phi.
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi);

/// Inverse of the left Jacobian of SO(3) at phi.
Eigen::Matrix3d LeftJacobianInvSO3(const Eigen::Vector3d& phi);

/// A rigid-body transform: unit quaternion rotation and translation.
class SE3 {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

  /// Identity transform.
  SE3() : q_(Eigen::Quaterniond::Identity()), t_(Eigen::Vector3d::Zero()) {}
  /// From a rotation (normalised here) and a translation.
  SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : q_(q.normalized()), t_(t) {}
  /// From a rotation matrix (re-orthonormalised through the quaternion) and a translation.
  SE3(const Eigen::Matrix3d& R, const Eigen::Vector3d& t)
      : q_(Eigen::Quaterniond(R).normalized()), t_(t) {}

  /// From a homogeneous 4x4 matrix (last row ignored).
  static SE3 FromMatrix(const Eigen::Matrix4d& T);
  /// Exponential map of a twist xi = [rho; phi].
  static SE3 Exp(const Vector6d& xi);
  /// Logarithm: the twist [rho; phi] with Exp(Log()) == *this.
  Vector6d Log() const;

  const Eigen::Quaterniond& so3() const { return q_; }
  Eigen::Matrix3d rotation() const { return q_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return t_; }
  Eigen::Vector3d& translation() { return t_; }
  /// Homogeneous 4x4 matrix.
  Eigen::Matrix4d matrix() const;
  /// Top 3x4 block [R | t].
  Eigen::Matrix<double, 3, 4> matrix3x4() const;

  SE3 inverse() const;
  SE3 operator*(const SE3& other) const { return SE3(q_ * other.q_, t_ + q_ * other.t_); }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q_ * p + t_; }

  /// Adjoint matrix in [rho; phi] order: Exp(Ad * xi) = T * Exp(xi) * T^-1.
  Matrix6d Adjoint() const;

  /// Rotation angle in radians (0..pi).
  double RotationAngle() const;

  /// True when every coefficient is finite.
  bool IsFinite() const;

 private:
  Eigen::Quaterniond q_;
  Eigen::Vector3d t_;
};

}  // namespace pl_slam
