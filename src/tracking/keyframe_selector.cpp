#include "pl_slam/tracking/keyframe_selector.h"
#include "pl_slam/util/validation.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

std::string KeyframeSelectorOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("entropy_ratio", entropy_ratio, 0.0, 1.0, true));
  check(CheckRange("min_frames", min_frames, 1, 100000));
  check(CheckRange("max_frames", max_frames, min_frames, 100000));
  check(CheckRange("idle_min_frames", idle_min_frames, 0, 100000));
  check(CheckRange("min_inliers", min_inliers, 0, 1000000));
  check(CheckRange("max_translation", max_translation, 0.0, 1e6, true));
  check(CheckRange("max_rotation_deg", max_rotation_deg, 0.0, 180.0, true));
  check(CheckRange("min_translation", min_translation, 0.0, max_translation));
  check(CheckRange("min_rotation_deg", min_rotation_deg, 0.0, max_rotation_deg));
  return first;
}

const char* KeyframeReasonName(KeyframeReason reason) {
  switch (reason) {
    case KeyframeReason::kNone:
      return "none";
    case KeyframeReason::kFirst:
      return "first";
    case KeyframeReason::kEntropy:
      return "entropy";
    case KeyframeReason::kFewInliers:
      return "few_inliers";
    case KeyframeReason::kLargeMotion:
      return "large_motion";
    case KeyframeReason::kMaxFrames:
      return "max_frames";
    case KeyframeReason::kMappingIdle:
      return "mapping_idle";
    case KeyframeReason::kInvalidInput:
      return "invalid_input";
  }
  return "unknown";
}

double Entropy(const Matrix6d& cov) {
  if (!cov.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  const Matrix6d sym = 0.5 * (cov + cov.transpose());
  Eigen::LLT<Matrix6d> llt(sym);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  // log |Sigma| = 2 sum log L_ii: no overflow or underflow of the determinant itself.
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  return 3.0 * (1.0 + std::log(2.0 * kPi)) + 0.5 * log_det;
}

KeyframeSelector::KeyframeSelector(const KeyframeSelectorOptions& options) : options_(options) {
  const std::string bad = options_.Validate();
  if (!bad.empty()) throw ConfigError("keyframe selector: " + bad);
}

void KeyframeSelector::Reset() {
  has_keyframe_ = false;
  Restart();
  last_entropy_ = 0.0;
  last_ratio_ = 1.0;
}

void KeyframeSelector::Restart() {
  restart_pending_ = false;
  T_kf_cur_ = SE3();
  cov_kf_cur_.setZero();
  frames_ = 0;
  first_entropy_ = 0.0;
}

KeyframeReason KeyframeSelector::AddFrame(const SE3& T_prev_cur, const Matrix6d& cov_prev_cur,
                                          int inliers, bool mapping_idle) {
  if (!has_keyframe_) {
    Restart();
    has_keyframe_ = true;
    last_entropy_ = 0.0;
    last_ratio_ = 1.0;
    restart_pending_ = true;
    return KeyframeReason::kFirst;
  }
  if (restart_pending_) Restart();

  const Matrix6d cov = 0.5 * (cov_prev_cur + cov_prev_cur.transpose());
  // Entropy() is finite exactly when the matrix is finite and positive definite.
  if (!T_prev_cur.IsFinite() || !std::isfinite(Entropy(cov))) {
    last_ratio_ = 1.0;
    restart_pending_ = true;
    return KeyframeReason::kInvalidInput;
  }

  // First-order propagation for left perturbations (see the header).
  const Matrix6d Ad = T_kf_cur_.Adjoint();
  cov_kf_cur_ += Ad * cov * Ad.transpose();
  cov_kf_cur_ = 0.5 * (cov_kf_cur_ + cov_kf_cur_.transpose()).eval();
  T_kf_cur_ = T_kf_cur_ * T_prev_cur;
  ++frames_;

  // A sum of positive definite matrices is positive definite: finite whenever the input was.
  const double h = Entropy(cov_kf_cur_);
  if (frames_ == 1) first_entropy_ = h;
  last_entropy_ = h;
  last_ratio_ = first_entropy_ != 0.0 ? h / first_entropy_ : 1.0;

  KeyframeReason reason = KeyframeReason::kNone;
  constexpr double kDegPerRad = 180.0 / kPi;
  if (inliers < options_.min_inliers) {
    reason = KeyframeReason::kFewInliers;
  } else if (T_kf_cur_.translation().norm() > options_.max_translation ||
             T_kf_cur_.RotationAngle() * kDegPerRad > options_.max_rotation_deg) {
    reason = KeyframeReason::kLargeMotion;
  } else if (T_kf_cur_.translation().norm() <= options_.min_translation &&
             T_kf_cur_.RotationAngle() * kDegPerRad <= options_.min_rotation_deg &&
             (options_.min_translation > 0.0 || options_.min_rotation_deg > 0.0)) {
    reason = KeyframeReason::kNone;  // at rest since the keyframe: nothing new to map
  } else if (frames_ >= options_.max_frames) {
    reason = KeyframeReason::kMaxFrames;
  } else if (mapping_idle && options_.idle_min_frames > 0 && frames_ >= options_.idle_min_frames) {
    reason = KeyframeReason::kMappingIdle;
  } else if (frames_ >= options_.min_frames &&
             h - first_entropy_ > (1.0 - options_.entropy_ratio) * std::abs(first_entropy_)) {
    reason = KeyframeReason::kEntropy;
  }
  if (reason != KeyframeReason::kNone) restart_pending_ = true;
  return reason;
}

}  // namespace pl_slam
