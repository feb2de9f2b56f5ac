#include "pl_slam/eval/alignment.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

namespace {

// Below this RMS spread (metres) a point set has no usable shape for estimating a scale.
constexpr double kMinSpread = 1e-9;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Poses(std::size_t n) { return std::to_string(n) + (n == 1 ? " pose" : " poses"); }

}  // namespace

AlignmentMode ParseAlignmentMode(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "none") return AlignmentMode::kNone;
  if (n == "first-pose" || n == "first_pose" || n == "first") return AlignmentMode::kFirstPose;
  if (n == "se3") return AlignmentMode::kSE3;
  if (n == "sim3") return AlignmentMode::kSim3;
  throw ConfigError("alignment '" + name + "': expected one of none, first-pose, se3, sim3");
}

std::string AlignmentModeName(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kFirstPose:
      return "first-pose";
    case AlignmentMode::kSE3:
      return "se3";
    case AlignmentMode::kSim3:
      return "sim3";
  }
  return "unknown";
}

Eigen::Vector3d Alignment::Apply(const Eigen::Vector3d& p_est) const {
  return scale * (T_gt_est.so3() * p_est) + T_gt_est.translation();
}

SE3 Alignment::Apply(const SE3& T_est) const {
  return SE3(T_gt_est.so3() * T_est.so3(), Apply(T_est.translation()));
}

Alignment UmeyamaAlignment(const Points3d& src, const Points3d& dst, bool with_scale) {
  if (src.size() != dst.size()) {
    throw InputError("umeyama alignment: " + std::to_string(src.size()) + " source points vs " +
                     std::to_string(dst.size()) + " target points");
  }
  if (src.empty()) throw InputError("umeyama alignment: no point pairs");
  const double n = static_cast<double>(src.size());

  Eigen::Vector3d mu_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mu_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    mu_src += src[i];
    mu_dst += dst[i];
  }
  mu_src /= n;
  mu_dst /= n;

  double var_src = 0.0;
  double var_dst = 0.0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // (1/n) sum (dst - mu_dst)(src - mu_src)^T
  for (std::size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d a = src[i] - mu_src;
    const Eigen::Vector3d b = dst[i] - mu_dst;
    var_src += a.squaredNorm();
    var_dst += b.squaredNorm();
    cov += b * a.transpose();
  }
  var_src /= n;
  var_dst /= n;
  cov /= n;

  if (with_scale) {
    if (std::sqrt(var_src) < kMinSpread) {
      throw InputError("sim3 alignment: the estimate positions are all identical (" +
                       Poses(src.size()) + "), the scale is undefined");
    }
    if (std::sqrt(var_dst) < kMinSpread) {
      throw InputError("sim3 alignment: the ground-truth positions are all identical (" +
                       Poses(dst.size()) + "), the scale is undefined");
    }
  }

  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double scale = 1.0;
  if (cov.norm() > 0.0) {
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d& U = svd.matrixU();
    const Eigen::Matrix3d& V = svd.matrixV();
    // Reflection handling: flip the axis of the smallest singular value when U V^T would be
    // a reflection, so R is a proper rotation (Umeyama eq. 39-43).
    Eigen::Vector3d s(1.0, 1.0, 1.0);
    if (U.determinant() * V.determinant() < 0.0) s(2) = -1.0;
    R = U * s.asDiagonal() * V.transpose();
    if (with_scale) scale = svd.singularValues().dot(s) / var_src;
  }

  Alignment out;
  out.mode = with_scale ? AlignmentMode::kSim3 : AlignmentMode::kSE3;
  out.scale = scale;
  out.T_gt_est = SE3(R, mu_dst - scale * R * mu_src);
  return out;
}

Alignment AlignTrajectories(const Association& association, AlignmentMode mode) {
  if (association.empty()) throw InputError("alignment: no associated pose pairs");
  Alignment out;
  out.mode = mode;
  switch (mode) {
    case AlignmentMode::kNone:
      return out;
    case AlignmentMode::kFirstPose:
      out.T_gt_est = association.gt.front().T_w_c * association.est.front().T_w_c.inverse();
      return out;
    case AlignmentMode::kSE3:
    case AlignmentMode::kSim3: {
      Points3d src;
      Points3d dst;
      src.reserve(association.size());
      dst.reserve(association.size());
      for (std::size_t i = 0; i < association.size(); ++i) {
        src.push_back(association.est[i].T_w_c.translation());
        dst.push_back(association.gt[i].T_w_c.translation());
      }
      return UmeyamaAlignment(src, dst, mode == AlignmentMode::kSim3);
    }
  }
  return out;
}

Trajectory ApplyAlignment(const Trajectory& traj, const Alignment& alignment) {
  Trajectory out = traj;
  for (StampedPose& p : out) p.T_w_c = alignment.Apply(p.T_w_c);
  return out;
}

}  // namespace eval
}  // namespace pl_slam
