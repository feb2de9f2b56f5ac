#include "pl_slam/optimization/line_cost.h"

#include <algorithm>
#include <cmath>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/optimization/se3_manifold.h"

namespace pl_slam {

Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d l =
      Eigen::Vector3d(a.x(), a.y(), 1.0).cross(Eigen::Vector3d(b.x(), b.y(), 1.0));
  const double n = l.head<2>().norm();
  return n > 0.0 ? Eigen::Vector3d(l / n) : Eigen::Vector3d::Zero();
}

namespace {

/// The landmark's endpoints in the camera frame of parameter block 0 (T_c_w) and its rotation.
struct CameraEndpoints {
  Eigen::Matrix3d R;
  Eigen::Vector3d X[2];
};

CameraEndpoints ToCamera(double const* const* parameters) {
  const SE3 T_c_w = SE3FromParams(parameters[0]);
  return {T_c_w.rotation(),
          {T_c_w * Eigen::Map<const Eigen::Vector3d>(parameters[1]),
           T_c_w * Eigen::Map<const Eigen::Vector3d>(parameters[1] + 3)}};
}

/// Chains d(residuals)/d(X_k) (camera-frame endpoints) to the lifted pose Jacobian and the
/// landmark's [P_w; Q_w] Jacobian.
template <int kResiduals>
void ChainToParameters(const Eigen::Matrix<double, kResiduals, 3> (&J_X)[2],
                       const CameraEndpoints& c, double** jacobians) {
  if (!jacobians) return;
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, kResiduals, 7, Eigen::RowMajor>> J(jacobians[0]);
    J.setZero();
    for (int k = 0; k < 2; ++k) {
      J.template leftCols<3>() += J_X[k];
      J.template middleCols<3>(3) += -J_X[k] * Hat(c.X[k]);
    }
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, kResiduals, 6, Eigen::RowMajor>> J(jacobians[1]);
    J.template leftCols<3>() = J_X[0] * c.R;
    J.template rightCols<3>() = J_X[1] * c.R;
  }
}

}  // namespace

template <int kResiduals>
bool LineCost<kResiduals>::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const CameraEndpoints c = ToCamera(parameters);
  const Eigen::Vector3d(&X)[2] = c.X;
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> r(residuals);
  // Rows: left line at P, left line at Q, then (stereo) right line at P, right line at Q.
  Eigen::Matrix<double, kResiduals, 3> J_X[2];
  J_X[0].setZero();
  J_X[1].setZero();
  r.setZero();
  if (X[0].z() > min_depth_ && X[1].z() > min_depth_) {
    const double fx = camera_.fx, fy = camera_.fy;
    for (int view = 0; view < kResiduals / 2; ++view) {
      const Eigen::Vector3d& l = view == 0 ? l_ : l_right_;
      const double shift = view == 0 ? 0.0 : camera_.baseline;
      const double cx = view == 0 ? camera_.cx : camera_.cx + camera_.doffs;
      for (int k = 0; k < 2; ++k) {
        const double iz = 1.0 / X[k].z();
        const double u = fx * (X[k].x() - shift) * iz + cx;
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
  }
  ChainToParameters<kResiduals>(J_X, c, jacobians);
  return true;
}

template class LineCost<2>;
template class LineCost<4>;

double PixelToProjectedLine(const Eigen::Vector3d& m, const Eigen::Vector2d& px, double fx,
                            double fy, double cx, double cy, Eigen::Vector3d* d_m) {
  // The image line is K^-T m; its value at px is m . K^-1 (px, 1), normalised by the length of
  // its (u, v) part, sqrt((m0 / fx)^2 + (m1 / fy)^2).
  const Eigen::Vector3d x((px.x() - cx) / fx, (px.y() - cy) / fy, 1.0);
  const double a = m.x() / fx, b = m.y() / fy;
  const double n2 = a * a + b * b;
  if (!(n2 > 1e-24) || !std::isfinite(n2)) {
    if (d_m) d_m->setZero();
    return 0.0;
  }
  const double n = std::sqrt(n2);
  const double g = m.dot(x);
  if (d_m) *d_m = x / n - (g / (n2 * n)) * Eigen::Vector3d(a / fx, b / fy, 0.0);
  return g / n;
}

template <int kResiduals>
bool EndpointLineCost<kResiduals>::Evaluate(double const* const* parameters, double* residuals,
                                            double** jacobians) const {
  const CameraEndpoints c = ToCamera(parameters);
  const Eigen::Vector3d(&X)[2] = c.X;
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> r(residuals);
  // Rows: left s, left e, then (stereo) right s, right e.
  Eigen::Matrix<double, kResiduals, 3> J_X[2];
  J_X[0].setZero();
  J_X[1].setZero();
  r.setZero();
  if (std::max(X[0].z(), X[1].z()) > min_depth_) {
    for (int view = 0; view < kResiduals / 2; ++view) {
      const Eigen::Vector3d shift(view == 0 ? 0.0 : camera_.baseline, 0.0, 0.0);
      const double cx = view == 0 ? camera_.cx : camera_.cx + camera_.doffs;
      const Eigen::Vector3d P = X[0] - shift, Q = X[1] - shift;
      const Eigen::Vector3d m = P.cross(Q);
      for (int k = 0; k < 2; ++k) {
        const int row = 2 * view + k;
        Eigen::Vector3d d_m;
        r(row) = sqrt_info_ *
                 PixelToProjectedLine(m, obs_[row], camera_.fx, camera_.fy, cx, camera_.cy, &d_m);
        // m = P x Q: dm/dP = -[Q]x, dm/dQ = [P]x.
        J_X[0].row(row) = -sqrt_info_ * d_m.transpose() * Hat(Q);
        J_X[1].row(row) = sqrt_info_ * d_m.transpose() * Hat(P);
      }
    }
  }
  ChainToParameters<kResiduals>(J_X, c, jacobians);
  return true;
}

template class EndpointLineCost<2>;
template class EndpointLineCost<4>;

bool AnchorSegmentToObservation(const StereoCamera& camera, const SE3& T_w_c,
                                const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                                Eigen::Vector3d* P_w, Eigen::Vector3d* Q_w) {
  const Eigen::Vector3d a = *P_w;
  const double length = (*Q_w - a).norm();
  if (!(length > 1e-9) || !std::isfinite(length)) return false;
  const Eigen::Vector3d d = (*Q_w - a) / length;
  const Eigen::Vector3d C = T_w_c.translation();
  Eigen::Vector3d out[2];
  const Eigen::Vector2d px[2] = {s, e};
  for (int k = 0; k < 2; ++k) {
    // Closest points of the line a + t d and the ray C + u r (both unit directions).
    const Eigen::Vector3d r =
        (T_w_c.rotation() * Eigen::Vector3d((px[k].x() - camera.cx) / camera.fx,
                                            (px[k].y() - camera.cy) / camera.fy, 1.0))
            .normalized();
    const double b = d.dot(r);
    const double denom = 1.0 - b * b;  // sin^2 of the angle between line and ray
    if (denom < std::pow(std::sin(2.0 * M_PI / 180.0), 2)) return false;
    const Eigen::Vector3d w = a - C;
    const double t = (b * r.dot(w) - d.dot(w)) / denom;
    const double u = (r.dot(w) - b * d.dot(w)) / denom;
    if (u <= 0.0) return false;  // behind the camera
    out[k] = a + t * d;
  }
  if ((out[1] - out[0]).norm() < 0.01) return false;
  *P_w = out[0];
  *Q_w = out[1];
  return true;
}

LineExtentCost::LineExtentCost(const Eigen::Vector3d& P0, const Eigen::Vector3d& Q0, double weight)
    : P0_(P0), Q0_(Q0), d_(Eigen::Vector3d::Zero()) {
  const double n = (Q0 - P0).norm();
  if (n > 1e-9 && std::isfinite(n)) d_ = weight * (Q0 - P0) / n;
}

bool LineExtentCost::Evaluate(double const* const* parameters, double* residuals,
                              double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> P(parameters[0]), Q(parameters[0] + 3);
  residuals[0] = d_.dot(P - P0_);
  residuals[1] = d_.dot(Q - Q0_);
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> J(jacobians[0]);
    J.setZero();
    J.block<1, 3>(0, 0) = d_.transpose();
    J.block<1, 3>(1, 3) = d_.transpose();
  }
  return true;
}

}  // namespace pl_slam
