// Keyframe selection from the uncertainty of the motion since the last keyframe (paper Section
// IV-D, after Kerl et al. 2013), with safety triggers.
//
// Conventions: the selector chains frame-to-frame increments T_prev_cur (T_a_b maps frame-b
// points into frame a, see se3.h) into T_kf_cur = T_kf_prev * T_prev_cur. Covariances are of
// LEFT perturbations in [rho; phi] order: T_true = Exp(e) * T_est, e ~ N(0, Sigma) -- i.e.
// MotionEstimate::covariance_prev_cur, not MotionEstimate::covariance. To first order
//   Sigma_kf_cur = Sigma_kf_prev + Ad(T_kf_prev) * Sigma_prev_cur * Ad(T_kf_prev)^T
// (increments assumed independent), because Exp(a) T1 Exp(b) T2 = Exp(a) Exp(Ad(T1) b) T1 T2.
#pragma once

#include <string>

#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// Options of KeyframeSelector.
struct KeyframeSelectorOptions {
  /// Keyframe when h(kf, cur) / h(kf, kf + 1) drops below this (paper: 0.9); see AddFrame for
  /// the sign convention.
  double entropy_ratio = 0.9;
  /// The entropy test is applied from the min_frames-th frame after a keyframe on: the first
  /// increments' covariances fluctuate and the ratio is 1 by definition at the first one.
  int min_frames = 3;
  /// Keyframe at the latest this many frames after the last one (the map must keep up even
  /// when the estimates are very certain, e.g. a slow camera in front of a textured wall).
  int max_frames = 30;
  /// When local mapping is idle (the caller says so per frame), a keyframe this many frames
  /// after the last one, once the camera has moved (min_translation / min_rotation_deg), as
  /// ORB-SLAM does: the map takes as many keyframes as mapping can process and culling removes
  /// the redundant ones later. 0 = off (the default: measured better on some sequences and
  /// worse on others, with twice the memory). Without
  /// mapping (visual odometry alone) it never fires.
  int idle_min_frames = 0;
  /// Keyframe when the current frame has fewer point + line inliers than this: the next frames
  /// would have too little to track against the old keyframe.
  int min_inliers = 40;
  /// Keyframe when the translation since the last keyframe exceeds this (metres): keeps
  /// keyframes overlapping even when the covariance is optimistic.
  double max_translation = 2.0;
  /// Keyframe when the rotation since the last keyframe exceeds this (degrees).
  double max_rotation_deg = 15.0;
  /// The entropy and frame-count triggers wait until the camera has moved more than this
  /// (metres) or turned more than min_rotation_deg since the keyframe: a camera at rest or a
  /// frozen image stream adds no keyframes (its uncertainty grows by chaining, its view does
  /// not change). 0 and 0 switch this off.
  double min_translation = 0.01;
  double min_rotation_deg = 0.5;  ///< see min_translation

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// Why AddFrame did (or did not) declare a keyframe.
enum class KeyframeReason {
  kNone,         ///< not a keyframe
  kFirst,        ///< first frame after construction or Reset()
  kEntropy,      ///< the entropy ratio fell below options.entropy_ratio
  kFewInliers,   ///< fewer inliers than options.min_inliers
  kLargeMotion,  ///< translation or rotation since the keyframe above the limits
  kMaxFrames,    ///< options.max_frames frames since the keyframe
  kMappingIdle,  ///< local mapping idle and options.idle_min_frames frames since the keyframe
  kInvalidInput  ///< non-finite increment, or covariance not finite and positive definite
};

/// Short name of a reason, e.g. "entropy", for logs and status messages.
const char* KeyframeReasonName(KeyframeReason reason);

/// Differential entropy of a 6-D Gaussian, h = 3 (1 + log 2 pi) + 0.5 log |Sigma| (paper eq. 2).
/// Units follow Sigma (metres, radians), so it is negative for any realistic motion estimate.
/// Returns -infinity for a singular or not positive definite Sigma and NaN for a non-finite one.
double Entropy(const Matrix6d& cov);

/// Decides which frames become keyframes from the chained frame-to-frame motion estimates.
/// Not thread-safe; one instance per tracker.
class KeyframeSelector {
 public:
  /// Throws ConfigError when options.Validate() fails.
  explicit KeyframeSelector(const KeyframeSelectorOptions& options);

  /// Forgets everything: the next AddFrame is the first frame (kFirst).
  void Reset();

  /// Adds the current frame with the increment T_prev_cur from the previous frame, its
  /// covariance (left perturbation of T_prev_cur, MotionEstimate::covariance_prev_cur) and its
  /// inlier count, and returns whether the current frame becomes a keyframe.
  ///
  /// - The first call after construction / Reset() returns kFirst; its increment is ignored.
  /// - A non-finite increment, or a covariance that is not finite and positive definite (a
  ///   failed estimate: MotionEstimate reports zeros on failure), returns kInvalidInput: the
  ///   uncertainty since the keyframe is unknown, so the frame is declared a keyframe rather
  ///   than guessed. T_kf_cur and its covariance are then left as they were (up to the
  ///   previous frame) and no NaN reaches the decision.
  /// - Otherwise the increment is chained and, in order: kFewInliers, kLargeMotion, kMaxFrames,
  ///   kMappingIdle (when `mapping_idle`), then kEntropy (only from min_frames frames after the
  ///   keyframe). The entropy test is the paper's alpha = h(kf, cur) / h(kf, kf + 1) <
  ///   entropy_ratio, evaluated in the equivalent form h(kf, cur) - h(kf, kf + 1) > (1 -
  ///   entropy_ratio) |h(kf, kf + 1)|. Both are identical when h(kf, kf + 1) < 0 (geometric-mean
  ///   standard deviation below ~0.24 m / rad, i.e. every usable estimate): entropies are negative,
  ///   accumulating uncertainty raises h towards 0 and alpha falls. When h(kf, kf + 1) >= 0 the
  ///   paper's ratio would rise instead and never fire; the difference form still fires once the
  ///   entropy has grown by that margin.
  ///
  /// After a keyframe decision T_kf_cur() / covariance_kf_cur() still describe the motion from
  /// the old keyframe to this (new) keyframe -- what local mapping refines -- and the next
  /// AddFrame restarts the chain from this frame.
  KeyframeReason AddFrame(const SE3& T_prev_cur, const Matrix6d& cov_prev_cur, int inliers,
                          bool mapping_idle = false);

  /// Paper's alpha for the last frame, h(kf, cur) / h(kf, kf + 1); 1 when undefined (first
  /// frames, invalid input, h(kf, kf + 1) == 0).
  double last_entropy_ratio() const { return last_ratio_; }
  /// Entropy h(kf, cur) of the last frame (0 before any increment has been chained).
  double last_entropy() const { return last_entropy_; }
  /// Motion from the last keyframe to the last added frame (see AddFrame after a keyframe).
  const SE3& T_kf_cur() const { return T_kf_cur_; }
  /// Covariance of a left perturbation of T_kf_cur().
  const Matrix6d& covariance_kf_cur() const { return cov_kf_cur_; }
  /// Increments chained since the last keyframe, including the last added frame.
  int frames_since_keyframe() const { return frames_; }
  /// The options in use.
  const KeyframeSelectorOptions& options() const { return options_; }

 private:
  // Starts a new chain at the current frame.
  void Restart();

  KeyframeSelectorOptions options_;
  bool has_keyframe_ = false;     // false until the first frame
  bool restart_pending_ = false;  // the last frame was a keyframe: chain from it next time
  SE3 T_kf_cur_;
  Matrix6d cov_kf_cur_ = Matrix6d::Zero();
  int frames_ = 0;
  double first_entropy_ = 0.0;  // h(kf, kf + 1)
  double last_entropy_ = 0.0;
  double last_ratio_ = 1.0;
};

}  // namespace pl_slam
