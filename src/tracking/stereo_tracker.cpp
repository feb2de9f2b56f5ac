#include "pl_slam/tracking/stereo_tracker.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "pl_slam/matching/patch_alignment.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"
#include "pl_slam/util/worker_thread.h"

namespace pl_slam {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Detections of one image before stereo matching.
struct ImageFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat point_descriptors;
  LineFeatures lines;
  cv::Mat line_descriptors;
};

}  // namespace

struct StereoTracker::Impl {
  StereoCamera camera;
  TrackerOptions options;
  PointDetector point_detector;
  LineDetector line_detector;
  KeyframeSelector selector;
  bool use_points = true, use_lines = true;

  bool has_previous = false;
  bool initialized = false;
  StereoFeatures previous;
  SE3 T_w_c;
  // Pose given to `previous` and the frames since it: a frame without features (blank) does
  // not replace it, while the motion model may still move T_w_c on.
  SE3 T_w_previous;
  int frames_since_previous = 0;
  // The last keyframe (track_keyframe): its features, in its camera frame, and its pose.
  bool has_keyframe = false;
  StereoFeatures keyframe;
  // The left images of `previous` and `keyframe` (copies, shared by the two when the previous
  // frame is the keyframe), for the patch alignment of frame-to-frame point matches.
  cv::Mat previous_left, keyframe_left;
  SE3 T_w_keyframe;
  SE3 velocity_cur_prev;  // last T_cur_prev: the constant-velocity prior
  bool velocity_valid = false;
  // The covariance of velocity_cur_prev (left perturbation of T_cur_prev) when it is a
  // tracked frame's estimate, not extrapolated or taken from a few-feature or direct one:
  // the model TrackFused may lean on.
  Matrix6d velocity_cov = Matrix6d::Zero();
  bool velocity_cov_valid = false;
  int predicted_frames = 0;  // consecutive lost frames whose pose the motion model gave
  TrackerState state = TrackerState::kNotInitialized;
  // Direct alignment's reference (TrackDirect): the last frame with a pose, its images (a
  // copy: callers may reuse their buffers), its pose and the frames since; the pixels with
  // depth are built on first use.
  cv::Mat last_left, last_right;  // the frame of the last Track() call (not copied)
  bool direct_valid = false;
  cv::Mat direct_left, direct_right;
  SE3 T_w_direct;
  int frames_since_direct = 0;
  bool direct_built = false;
  DirectReference direct_reference;
  WorkerThread right_worker;  // detects the right image's features (options.parallel)

  Impl(const StereoCamera& cam, const TrackerOptions& opt)
      : camera(cam),
        options(opt),
        point_detector(opt.points),
        line_detector(opt.lines),
        selector(opt.keyframes) {
    use_points = opt.mode != FeatureMode::kLines;
    use_lines = opt.mode != FeatureMode::kPoints;
  }

  void Detect(const cv::Mat& image, ImageFeatures* f) const {
    if (use_points) point_detector.Detect(image, &f->keypoints, &f->point_descriptors);
    if (use_lines) line_detector.Detect(image, &f->lines, &f->line_descriptors);
  }

  struct Estimation {
    MotionEstimate est;
    PointMatches3D2D points;  // the correspondences the estimate was given
    LineMatches3D2D lines;
    bool consensus_agreed = false;  // the hypothesis stage found a motion RelaxedFloor() support
    int point_matches = 0, line_matches = 0;
    double matching_ms = 0.0, motion_ms = 0.0;
  };
  // TrackFused: the last Track() call's frame-to-frame matches and prediction, when it lost
  // the frame right after a tracked one, and the pose of the frame they were matched to.
  bool fused_pending = false;
  Estimation fused_f2f;
  SE3 fused_prior, T_w_fused_ref;
  Matrix6d fused_velocity_cov = Matrix6d::Zero();

  /// Matches the features of a reference frame `ref` (with depth, in its camera frame) to the
  /// current frame, guided by `prior` (T_cur_ref) when given, and estimates T_cur_ref.
  /// `consensus`: run the hypothesis stage first (options.consensus.enabled permitting).
  Estimation EstimateAgainst(const StereoFeatures& ref, const cv::Mat& ref_left,
                             const StereoFeatures& cur, const cv::Mat& cur_left, const SE3* prior,
                             bool consensus) const {
    Estimation out;
    auto t0 = Clock::now();
    std::vector<std::pair<int, int>> point_matches, line_matches;
    // Guided by the prediction; where it finds few, also everywhere (the prediction may be
    // wrong after a sudden change of motion), keeping the search with more matches.
    if (use_points) {
      point_matches =
          prior ? MatchPointsPredicted(camera, ref.points, ref.point_descriptors, cur.points,
                                       cur.point_descriptors, options.point_matching, *prior,
                                       2 * options.min_inliers)
                : MatchPointsFrameToFrame(camera, ref.points, ref.point_descriptors, cur.points,
                                          cur.point_descriptors, options.point_matching);
    }
    if (use_lines) {
      LinePrediction prediction;
      if (prior) prediction.T_cur_prev = *prior;
      prediction.camera = camera;
      line_matches = prior ? MatchLinesPredicted(ref.lines, ref.line_descriptors, cur.lines,
                                                 cur.line_descriptors, options.line_matching,
                                                 prediction, options.min_inliers)
                           : MatchLines(ref.lines, ref.line_descriptors, cur.lines,
                                        cur.line_descriptors, options.line_matching);
    }
    out.point_matches = static_cast<int>(point_matches.size());
    out.line_matches = static_cast<int>(line_matches.size());
    out.matching_ms = MsSince(t0);

    t0 = Clock::now();
    const Eigen::Vector3d kUnknown = Eigen::Vector3d::Constant(std::nan(""));
    PointMatches3D2D pm;
    LineMatches3D2D lm;
    Points3D points_cur, lines_cur_P, lines_cur_Q;  // current-frame stereo 3D, for consensus
    pm.reserve(point_matches.size());
    // Where the reference patch aligns (f2f_align_max_shift), when the prediction says the
    // view does not warp it.
    const double max_shift = options.point_matching.f2f_align_max_shift;
    const bool align = max_shift > 0.0 && prior && !ref_left.empty() && !cur_left.empty();
    for (const auto& [i, j] : point_matches) {
      PointMatch3D2D m;
      m.P_prev = ref.points[i].p_c;
      m.uv_cur = cur.points[j].uv;
      if (align &&
          PatchWarp(camera, *prior, ref.points[i].uv, ref.points[i].p_c.z()) <= kMaxPatchWarp) {
        Eigen::Vector2d offset;
        if (AlignPatch(TakePatch(ref_left, ref.points[i].uv), cur_left, m.uv_cur, max_shift,
                       &offset))
          m.uv_cur += offset;
      }
      // Keypoints of coarser pyramid levels are localised less precisely.
      m.weight = std::pow(options.points.scale_factor, -2.0 * cur.points[j].octave);
      m.depth_noise = options.depth_noise;
      m.u_right_cur = cur.points[j].u_right();
      pm.push_back(m);
      points_cur.push_back(cur.points[j].has_depth ? cur.points[j].p_c : kUnknown);
    }
    for (const auto& [i, j] : line_matches) {
      const LineFeature& lr = ref.lines[i];
      if (!lr.has_depth) continue;
      LineMatch3D2D m;
      m.P_prev = lr.P_c;
      m.Q_prev = lr.Q_c;
      m.l_cur = cur.lines[j].l;
      m.weight = options.line_weight;
      // Endpoint disparities come from crossing the image rows: the flatter, the noisier;
      // those taken at junctions are the steeper segments' there.
      m.depth_noise = lr.depth_from_junctions
                          ? options.depth_noise
                          : options.depth_noise / std::max(std::abs(std::sin(lr.angle)), 0.1);
      lm.push_back(m);
      const LineFeature& lc = cur.lines[j];
      lines_cur_P.push_back(lc.has_depth ? lc.P_c : kUnknown);
      lines_cur_Q.push_back(lc.has_depth ? lc.Q_c : kUnknown);
    }
    SE3 start = prior ? *prior : SE3();
    if (consensus && options.consensus.enabled) {
      // Consensus before refinement: the refinement starts at the pose most correspondences
      // agree with and never sees the ones far from it.
      std::vector<SE3> candidates{start};
      if (prior) candidates.push_back(SE3());
      // Support down to the relaxed gate's count: whether such a pose is kept is the gates'
      // decision (Track), but the refinement should start from it.
      const ConsensusResult c =
          FindMotionConsensus(camera, pm, points_cur, lm, lines_cur_P, lines_cur_Q, candidates,
                              RelaxedFloor(), options.consensus);
      if (c.success) {
        out.consensus_agreed = true;
        start = c.T_cur_prev;
        pm = Gated(pm, c.point_gate);
        lm = Gated(lm, c.line_gate);
      }
    }
    out.est = EstimateMotion(camera, pm, lm, start, options.motion);
    out.points = std::move(pm);
    out.lines = std::move(lm);
    out.motion_ms = MsSince(t0);
    return out;
  }

  /// The rotation of a frame too poor for a whole estimate, about the camera centre the
  /// motion model predicts (`predicted`, T_cur_prev): its correspondences fitted for the
  /// rotation alone. Kept with lost_rotation_min_inliers, a rotation standard deviation within
  /// relaxed_max_deviation_deg and a turn within relaxed_max_deviation_deg of the prediction
  /// (the relaxed gate's: a few features can fit a wrong roll as tightly as the right one).
  bool RotationAbout(const Estimation& f2f, const SE3& predicted, SE3* T_cur_prev) const {
    if (options.lost_rotation_min_inliers <= 0 ||
        static_cast<int>(f2f.points.size() + f2f.lines.size()) < options.lost_rotation_min_inliers)
      return false;
    MotionEstimatorOptions rot = options.motion;
    rot.rotation_only = true;
    rot.min_inliers = options.lost_rotation_min_inliers;
    const MotionEstimate est = EstimateMotion(camera, f2f.points, f2f.lines, predicted, rot);
    if (!est.success) return false;
    const double max_rad = options.relaxed_max_deviation_deg * M_PI / 180.0;
    if (!(est.covariance.bottomRightCorner<3, 3>().diagonal().maxCoeff() <= max_rad * max_rad))
      return false;
    const SE3 change = est.T_cur_prev * predicted.inverse();
    if (change.RotationAngle() > max_rad) return false;
    *T_cur_prev = est.T_cur_prev;
    return true;
  }

  /// A frame too poor for its own estimate, fitted together with the constant-velocity
  /// prediction `prior` (T_cur_prev) as a Gaussian prior (TrackerOptions::fused_min_inliers).
  /// True with the estimate when the gates there hold.
  bool FusedWithPrior(const Estimation& f2f, const SE3& prior, const Matrix6d& velocity_cov,
                      MotionEstimate* out) const {
    const int n = static_cast<int>(f2f.points.size() + f2f.lines.size());
    if (options.fused_min_inliers <= 0 || n < options.fused_min_inliers) return false;
    MotionEstimatorOptions fused = options.motion;
    fused.rotation_only = false;
    // The frame's own disparities measure the distance to the few features, which their
    // spread in the image (a switch plate) does not.
    fused.stereo_residual = true;
    fused.min_inliers = options.fused_min_inliers;
    // The prediction's uncertainty: the last motion's own, plus the change of motion a frame
    // allows (the model's process noise).
    const double st = options.fused_sigma, sr = options.fused_sigma_deg * M_PI / 180.0;
    Matrix6d prior_cov = velocity_cov;
    prior_cov.diagonal() +=
        (Vector6d() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr).finished();
    const MotionEstimate est =
        EstimateMotion(camera, f2f.points, f2f.lines, prior, fused, &prior_cov);
    if (!est.success) return false;
    // The deviation within the prior's 99 % bound (chi2 with 6 dof) and the relaxed gate's:
    // features that pull the pose further disagree with the model, and one of them is wrong.
    const Vector6d d = (est.T_cur_prev * prior.inverse()).Log();
    const double m2 = d.dot(prior_cov.ldlt().solve(d));
    constexpr double kChi2SixDof99 = 16.81;
    if (!(m2 <= kChi2SixDof99) || !AgreesWithModel(est.T_cur_prev, prior) ||
        !WithinRelaxedSigma(est.covariance_prev_cur))
      return false;
    *out = est;
    return true;
  }

  /// The deviation of T_cur_prev from the model's `prior` within the relaxed gate's.
  bool AgreesWithModel(const SE3& T_cur_prev, const SE3& prior) const {
    const SE3 deviation = T_cur_prev * prior.inverse();
    return deviation.translation().norm() <= options.relaxed_max_deviation &&
           deviation.RotationAngle() <= options.relaxed_max_deviation_deg * M_PI / 180.0;
  }

  /// The last Track() call's frame, at T_w, becomes direct alignment's reference.
  void KeepForDirect(const SE3& T_w) {
    if (!options.direct.enabled || last_left.empty()) return;
    last_left.copyTo(direct_left);
    last_right.copyTo(direct_right);
    T_w_direct = T_w;
    frames_since_direct = 0;
    direct_valid = true;
    direct_built = false;
  }

  /// A lost frame given a pose from outside frame-to-frame tracking (the local map, direct
  /// alignment): tracking resumes from it with the motion prior kept, a new keyframe chain, and
  /// it as direct alignment's reference.
  void ResumeAt(const SE3& T_w) {
    T_w_c = T_w;
    state = TrackerState::kTracking;
    predicted_frames = 0;
    selector.Reset();
    selector.AddFrame(SE3(), Matrix6d::Identity(), 0);
    has_keyframe = false;
    KeepForDirect(T_w);
  }

  /// A frame Track() lost, given a pose by a fallback (TrackDirect, TrackFused): it becomes
  /// the next frame's reference at T_w (when its features already are, Track), tracking
  /// resumes from it, and `r` reports it tracked with the increment and its covariance; the
  /// caller sets its own flag.
  void MarkTracked(const SE3& T_w, const SE3& T_prev_cur, const Matrix6d& cov_prev_cur,
                   TrackerResult* r) {
    if (frames_since_previous == 0) T_w_previous = T_w;
    ResumeAt(T_w);
    r->pose_valid = true;
    r->state = TrackerState::kTracking;
    r->T_w_c = T_w;
    r->T_prev_cur = T_prev_cur;
    r->covariance_prev_cur = cov_prev_cur;
    r->predicted = false;
    r->rotation_measured = false;
    r->is_keyframe = false;
    r->warning.clear();
  }

  /// Fewest inliers any gate keeps: relaxed_min_inliers when the relaxed gate is on.
  int RelaxedFloor() const {
    return options.relaxed_min_inliers > 0
               ? std::min(options.min_inliers, options.relaxed_min_inliers)
               : options.min_inliers;
  }

  /// The relaxed gate: an estimate with fewer than min_inliers but at least
  /// relaxed_min_inliers is kept when it agrees with the constant-velocity prediction (a
  /// corner with a dozen good features), and its own covariance is tight. Without a motion
  /// model (after a loss) there is nothing to agree with, and a few clustered features can
  /// trade rotation against translation by centimetres within their covariance: such an
  /// estimate is not kept but becomes the model the next frame must agree with (Track).
  bool AgreesWithPrior(const MotionEstimate& est, const SE3& prior) const {
    return AgreesWithModel(est.T_cur_prev, prior) && WellConstrained(est);
  }

  /// The relaxed gate's own conditions: at least relaxed_min_inliers, and the estimate's
  /// standard deviations within the relaxed deviations.
  bool WellConstrained(const MotionEstimate& est) const {
    if (options.relaxed_min_inliers <= 0 ||
        est.point_inliers + est.line_inliers < options.relaxed_min_inliers)
      return false;
    return WithinRelaxedSigma(est.covariance_prev_cur);
  }

  /// Standard deviations within relaxed_max_deviation(_deg): what any kept estimate needs.
  bool WithinRelaxedSigma(const Matrix6d& covariance) const {
    return SigmaWithin(covariance, options.relaxed_max_deviation,
                       options.relaxed_max_deviation_deg * M_PI / 180.0);
  }

  template <typename Matches>
  static Matches Gated(const Matches& all, const std::vector<uint8_t>& keep) {
    Matches kept;
    kept.reserve(all.size());
    for (std::size_t i = 0; i < all.size(); ++i)
      if (keep[i]) kept.push_back(all[i]);
    return kept;
  }
};

StereoTracker::StereoTracker(const StereoCamera& camera, const TrackerOptions& options) {
  const std::string cam_err = camera.Validate();
  if (!cam_err.empty()) throw ConfigError("camera: " + cam_err);
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError(err);
  impl_ = std::make_unique<Impl>(camera, options);
}

StereoTracker::~StereoTracker() = default;

const StereoFeatures& StereoTracker::last_features() const { return impl_->previous; }

void StereoTracker::Reset() {
  Impl& s = *impl_;
  s.has_previous = false;
  s.initialized = false;
  s.previous = StereoFeatures();
  s.previous_left.release();
  s.keyframe_left.release();
  s.T_w_c = SE3();
  s.T_w_previous = SE3();
  s.frames_since_previous = 0;
  s.velocity_cur_prev = SE3();
  s.velocity_valid = false;
  s.velocity_cov_valid = false;
  s.predicted_frames = 0;
  s.state = TrackerState::kNotInitialized;
  s.selector.Reset();
  s.has_keyframe = false;
  s.direct_valid = false;
}

void StereoTracker::Rescued(const SE3& T_w_c) {
  Impl& s = *impl_;
  if (!T_w_c.IsFinite()) return;
  s.T_w_previous = T_w_c;
  if (s.fused_pending) {
    // Lost right after a tracked frame: the motion model (the prediction, turned by the
    // frame's own rotation when it gave one) is as certain as that frame's measured motion.
    s.velocity_cov = s.fused_velocity_cov;
    s.velocity_cov_valid = true;
    s.fused_pending = false;
  }
  s.ResumeAt(T_w_c);
}

void StereoTracker::CorrectPose(const SE3& T_w_c) {
  Impl& s = *impl_;
  if (!T_w_c.IsFinite()) return;
  // The keyframe moves with the frame, so the next keyframe-relative pose is in the
  // corrected frame too.
  const SE3 correction = T_w_c * s.T_w_c.inverse();
  s.T_w_keyframe = correction * s.T_w_keyframe;
  s.T_w_previous = correction * s.T_w_previous;
  s.T_w_direct = correction * s.T_w_direct;
  s.T_w_c = T_w_c;
}

void StereoTracker::Relocalized(const SE3& T_w_c) {
  Impl& s = *impl_;
  if (!T_w_c.IsFinite()) return;
  s.T_w_c = T_w_c;
  s.T_w_previous = T_w_c;
  s.initialized = true;
  s.state = TrackerState::kTracking;
  s.velocity_valid = false;
  s.selector.Reset();
  s.selector.AddFrame(SE3(), Matrix6d::Identity(), 0);
  s.has_keyframe = false;
  s.KeepForDirect(T_w_c);
}

TrackerResult StereoTracker::Track(const StereoFrame& frame, bool mapping_idle) {
  Impl& s = *impl_;
  TrackerResult result;
  result.T_w_c = s.T_w_c;
  s.last_left = frame.left;
  s.last_right = frame.right;
  s.fused_pending = false;

  // 1. Features in both images; the right image on the tracker's helper thread (one thread
  //    for the tracker's life, see util/worker_thread.h).
  auto t0 = Clock::now();
  ImageFeatures left, right;
  if (s.options.parallel) {
    s.right_worker.Start([&] { s.Detect(frame.right, &right); });
    try {
      s.Detect(frame.left, &left);
    } catch (...) {
      s.right_worker.Wait();  // `right` must outlive the job
      throw;
    }
    s.right_worker.Wait();
  } else {
    s.Detect(frame.left, &left);
    s.Detect(frame.right, &right);
  }
  result.stage_ms.emplace_back("features", MsSince(t0));

  // 2. Stereo matching and triangulation.
  t0 = Clock::now();
  StereoFeatures cur;
  if (s.use_points) {
    result.points_stereo = MatchStereoPoints(
        s.camera, frame.left, frame.right, left.keypoints, left.point_descriptors, right.keypoints,
        right.point_descriptors, s.options.point_matching, &cur.points);
    cur.point_descriptors = left.point_descriptors;
  }
  if (s.use_lines) {
    result.lines_stereo = MatchStereoLines(
        s.camera, &left.lines, left.line_descriptors, right.lines, right.line_descriptors,
        s.options.line_matching, nullptr, frame.left, frame.right);
    cur.lines = std::move(left.lines);
    cur.line_descriptors = left.line_descriptors;
  }
  result.points_detected = static_cast<int>(cur.points.size());
  result.lines_detected = static_cast<int>(cur.lines.size());
  result.stage_ms.emplace_back("stereo", MsSince(t0));

  // 3-4. Frame-to-frame matching, guided by the constant-velocity prior when there is one,
  //      and robust motion estimation.
  // After frames without features the previous features are older: the prior spans the gap.
  if (s.has_previous) ++s.frames_since_previous;
  SE3 prior;
  for (int k = 0; k < std::min(s.frames_since_previous, 1000); ++k)
    prior = s.velocity_cur_prev * prior;
  if (!s.velocity_valid) prior = SE3();
  bool tracked = false;
  // A few-feature estimate without a motion model to check it against (after a loss): not
  // kept, but it becomes the motion model the next frame's estimate must agree with.
  bool candidate_motion = false;
  Impl::Estimation f2f;
  if (s.has_previous)
    f2f = s.EstimateAgainst(s.previous, s.previous_left, cur, frame.left,
                            s.velocity_valid ? &prior : nullptr, true);
  result.point_matches = f2f.point_matches;
  result.line_matches = f2f.line_matches;
  result.stage_ms.emplace_back("matching", f2f.matching_ms);
  if (s.has_previous) {
    const MotionEstimate& est = f2f.est;
    result.point_inliers = est.point_inliers;
    result.line_inliers = est.line_inliers;
    if (!est.success) {
      result.warning = "motion estimation failed: " + est.failure;
    } else if (est.point_inliers + est.line_inliers < s.options.min_inliers &&
               !(s.velocity_valid && s.AgreesWithPrior(est, prior))) {
      std::ostringstream os;
      os << "only " << est.point_inliers << " point and " << est.line_inliers
         << " line inliers (min_inliers=" << s.options.min_inliers << ")";
      result.warning = os.str();
      candidate_motion = !s.velocity_valid && f2f.consensus_agreed && s.WellConstrained(est);
    } else {
      const SE3 T_prev_cur = est.T_cur_prev.inverse();
      if (!T_prev_cur.IsFinite() || T_prev_cur.translation().norm() > s.options.max_translation ||
          T_prev_cur.RotationAngle() * 180.0 / M_PI > s.options.max_rotation_deg) {
        result.warning = "implausible frame-to-frame motion rejected";
      } else if (!s.WithinRelaxedSigma(est.covariance_prev_cur)) {
        // Enough inliers, but bunched where they leave the motion unobservable (a corner of
        // the image): kept, it would become the motion model the next frames follow.
        result.warning = "frame-to-frame motion too uncertain";
      } else {
        tracked = true;
        // Kept by the relaxed gate (too few inliers to stand alone, agreeing with the
        // prediction): the directions its few features leave weak (the distance to a small
        // cluster of corners) would come from their noise and become the model the next
        // frames follow. Fitted with the prediction as TrackFused's prior, they stay near it.
        MotionEstimate fused;
        if (s.options.relaxed_prior &&
            est.point_inliers + est.line_inliers < s.options.min_inliers && s.velocity_cov_valid &&
            s.frames_since_previous == 1 && s.FusedWithPrior(f2f, prior, s.velocity_cov, &fused)) {
          f2f.est = fused;
        }
        result.T_prev_cur = f2f.est.T_cur_prev.inverse();
        result.covariance_prev_cur = f2f.est.covariance_prev_cur;
      }
    }
  }
  result.stage_ms.emplace_back("motion", f2f.motion_ms);

  // 4b. The same against the last keyframe, predicted by the frame-to-frame pose: one
  //     estimate per keyframe interval instead of a chain of per-frame ones.
  if (tracked) {
    const SE3 T_w_prev = s.T_w_previous;
    SE3 T_w_cur = T_w_prev * result.T_prev_cur;
    if (s.options.track_keyframe && s.has_keyframe) {
      t0 = Clock::now();
      const SE3 predicted = T_w_cur.inverse() * s.T_w_keyframe;  // T_cur_keyframe
      // No consensus stage here: the prediction comes from this frame's own estimate, and the
      // refinement is refused beyond keyframe_max_correction or when the two estimates
      // disagree beyond their uncertainty (keyframe_max_chi2).
      const Impl::Estimation kf =
          s.EstimateAgainst(s.keyframe, s.keyframe_left, cur, frame.left, &predicted, false);
      const int kf_inliers = kf.est.point_inliers + kf.est.line_inliers;
      const int f2f_inliers = result.point_inliers + result.line_inliers;
      if (kf.est.success && kf_inliers >= s.options.min_inliers &&
          kf_inliers >= s.options.keyframe_min_inlier_ratio * f2f_inliers) {
        const SE3 refined = s.T_w_keyframe * kf.est.T_cur_prev.inverse();
        const SE3 change = T_w_cur.inverse() * refined;
        // Both covariances are of a perturbation in the current camera's frame.
        const Vector6d d = change.Log();
        const double m2 = d.dot((f2f.est.covariance + kf.est.covariance).ldlt().solve(d));
        if (refined.IsFinite() &&
            (s.options.keyframe_max_chi2 <= 0.0 || m2 <= s.options.keyframe_max_chi2) &&
            change.translation().norm() <= s.options.keyframe_max_correction &&
            change.RotationAngle() * 180.0 / M_PI <= s.options.keyframe_max_correction_deg) {
          T_w_cur = refined;
          result.keyframe_refined = true;
          // The increment follows the pose kept; the covariance stays the frame-to-frame
          // one (the keyframe selector chains increments since the keyframe).
          result.T_prev_cur = T_w_prev.inverse() * T_w_cur;
        }
      }
      result.stage_ms.emplace_back("keyframe_match", MsSince(t0));
    }
    s.T_w_c = T_w_cur;
    // Over a gap the increment spans several frames: the per-frame velocity is kept.
    if (s.frames_since_previous <= 1 || !s.velocity_valid) {
      s.velocity_cur_prev = result.T_prev_cur.inverse();
      s.velocity_valid = true;
      const Matrix6d Ad = s.velocity_cur_prev.Adjoint();
      s.velocity_cov = Ad * result.covariance_prev_cur * Ad.transpose();
      s.velocity_cov_valid = true;
    }
    s.predicted_frames = 0;
  }

  // 5. State, keyframe decision and the new reference frame.
  t0 = Clock::now();
  const int usable = result.points_stereo + result.lines_stereo;
  if (!s.initialized) {
    if (usable >= s.options.min_inliers) {
      s.initialized = true;
      tracked = true;
      s.selector.Reset();
      // Registers this frame as the chain's start (the increment of a first frame is ignored).
      result.keyframe_reason = s.selector.AddFrame(SE3(), Matrix6d::Identity(), usable);
      // The first pose defines the world: no motion, no uncertainty.
      result.T_prev_cur = SE3();
      result.covariance_prev_cur.setZero();
      result.is_keyframe = true;
    } else {
      std::ostringstream os;
      os << "only " << usable << " stereo features; waiting to initialise";
      result.warning = os.str();
    }
    s.state = s.initialized ? TrackerState::kTracking : TrackerState::kNotInitialized;
  } else if (tracked) {
    s.state = TrackerState::kTracking;
    result.keyframe_reason =
        s.selector.AddFrame(result.T_prev_cur, result.covariance_prev_cur,
                            result.point_inliers + result.line_inliers, mapping_idle);
    result.is_keyframe = result.keyframe_reason != KeyframeReason::kNone;
  } else {
    // Lost: this frame becomes the new reference. For a few frames the pose follows the
    // constant-velocity model (the camera keeps moving while it is not tracked), then it
    // stays at the last pose; after that, a few-feature estimate the consensus agrees with
    // becomes the model (confirmed or not by the next frame). The trajectory gets a gap (no
    // valid pose for this frame), never a jump; the caller is told why.
    s.state = TrackerState::kLost;
    s.selector.Reset();
    // Right after a tracked frame, this frame's matches may still hold with the model as a
    // prior (TrackFused, once the local map has had its chance).
    s.fused_pending = s.has_previous && s.velocity_valid && s.velocity_cov_valid &&
                      s.predicted_frames == 0 && s.frames_since_previous == 1 &&
                      s.options.fused_min_inliers > 0;
    s.velocity_cov_valid = false;  // whatever the model becomes below, it is not measured
    if (s.fused_pending) {
      s.fused_f2f = f2f;
      s.fused_prior = prior;
      s.fused_velocity_cov = s.velocity_cov;
      s.T_w_fused_ref = s.T_w_previous;
    }
    if (candidate_motion && s.options.max_predicted_frames > 0) {
      // Confirmation over two frames: a wrong few-feature estimate does not predict the
      // next frame's motion. The pose moves by it (the best guess, flagged as predicted) and
      // the motion model does not extend it if the next frame fails too.
      const SE3 T_prev_cur = f2f.est.T_cur_prev.inverse();
      s.T_w_c = s.T_w_previous * T_prev_cur;
      s.velocity_cur_prev = f2f.est.T_cur_prev;
      s.velocity_valid = true;
      s.predicted_frames = s.options.max_predicted_frames;
      result.predicted = true;
      result.T_prev_cur = T_prev_cur;
      result.covariance_prev_cur = f2f.est.covariance_prev_cur;
    } else {
      // The model: the constant velocity for max_predicted_frames, then no motion.
      const bool model_valid =
          s.velocity_valid && s.predicted_frames < s.options.max_predicted_frames;
      SE3 T_prev_cur = model_valid ? s.velocity_cur_prev.inverse() : SE3();
      // The matches, too few for the whole motion, may still hold the rotation: the position
      // follows the model, the orientation what the frame sees (only when the frame it was
      // matched to is the last one: no featureless frame came between). Past the model's
      // frames too, so a turn while lost is followed.
      SE3 T_cur_prev;
      const bool rotation = s.has_previous && s.frames_since_previous == 1 &&
                            s.RotationAbout(f2f, T_prev_cur.inverse(), &T_cur_prev);
      if (rotation) {
        T_prev_cur = T_cur_prev.inverse();
        result.rotation_measured = true;
      }
      // The motion model's uncertainty: the increment's own size as its standard deviation
      // (at least 1 cm and 0.5 deg), so a consumer never over-trusts a prediction. Without
      // one (the pose stays), the camera still moved unseen: by the last known motion's size,
      // so the odometry's uncertainty keeps growing over the whole gap.
      const SE3 size_of = model_valid || rotation ? T_prev_cur : s.velocity_cur_prev;
      const double st = std::max(0.01, size_of.translation().norm());
      const double sr = std::max(0.5 * M_PI / 180.0, size_of.RotationAngle());
      result.covariance_prev_cur.setZero();
      result.covariance_prev_cur.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
      if (model_valid || rotation) {
        s.T_w_c = s.T_w_c * T_prev_cur;
        result.predicted = true;
        result.T_prev_cur = T_prev_cur;
      }
      if (model_valid) {
        ++s.predicted_frames;
        s.velocity_cur_prev = T_prev_cur.inverse();
      } else {
        s.velocity_valid = false;
      }
    }
  }
  if (s.state != TrackerState::kTracking) s.has_keyframe = false;
  // The frame's left image, for aligning the next frames' matches (a copy: callers may reuse
  // their buffers).
  cv::Mat left_copy;
  if (s.use_points && s.options.point_matching.f2f_align_max_shift > 0.0 &&
      (usable > 0 || result.is_keyframe))
    left_copy = frame.left.clone();
  if (result.is_keyframe && s.options.track_keyframe) {
    s.keyframe_left = left_copy;
    s.keyframe = cur;
    s.T_w_keyframe = s.T_w_c;
    s.has_keyframe = true;
  }
  if (usable > 0) {
    s.previous_left = left_copy;
    s.previous = std::move(cur);
    s.has_previous = true;
    s.T_w_previous = s.T_w_c;
    s.frames_since_previous = 0;
  }
  if (tracked)
    s.KeepForDirect(s.T_w_c);
  else if (s.direct_valid)
    ++s.frames_since_direct;
  result.state = s.state;
  result.pose_valid = tracked;
  result.T_w_c = s.T_w_c;
  result.stage_ms.emplace_back("keyframe", MsSince(t0));
  return result;
}

bool StereoTracker::TrackFused(const StereoFrame& frame, TrackerResult* r) {
  Impl& s = *impl_;
  if (!s.fused_pending || r->pose_valid || frame.left.data != s.last_left.data) return false;
  s.fused_pending = false;
  const auto t0 = Clock::now();
  MotionEstimate est;
  const bool ok = s.FusedWithPrior(s.fused_f2f, s.fused_prior, s.fused_velocity_cov, &est);
  r->stage_ms.emplace_back("fused", MsSince(t0));
  if (!ok) return false;
  const SE3 T_prev_cur = est.T_cur_prev.inverse();
  const SE3 T_w_c = s.T_w_fused_ref * T_prev_cur;
  // The model becomes this motion with its uncertainty, prior included: the next frame's
  // prior is only as certain as this estimate was.
  s.velocity_cur_prev = est.T_cur_prev;
  s.velocity_cov = est.covariance;
  s.velocity_valid = true;
  s.velocity_cov_valid = true;
  s.MarkTracked(T_w_c, T_prev_cur, est.covariance_prev_cur, r);
  r->point_inliers = est.point_inliers;
  r->line_inliers = est.line_inliers;
  r->prior_fused = true;
  return true;
}

bool StereoTracker::TrackDirect(const StereoFrame& frame, TrackerResult* r) {
  Impl& s = *impl_;
  if (!s.options.direct.enabled || !s.direct_valid || r->pose_valid || !r->predicted ||
      s.frames_since_direct < 1 || frame.left.data != s.last_left.data)
    return false;
  const auto t0 = Clock::now();
  if (!s.direct_built) {
    s.direct_reference =
        BuildDirectReference(s.camera, s.direct_left, s.direct_right,
                             s.options.point_matching.max_disparity, s.options.direct);
    s.direct_built = true;
  }
  const SE3 prior = r->T_w_c.inverse() * s.T_w_direct;  // T_cur_ref, the motion model's
  const DirectAlignmentResult a =
      AlignDirect(s.camera, s.direct_reference, frame.left, prior, s.options.direct);
  r->stage_ms.emplace_back("direct", MsSince(t0));
  if (!a.success) {
    PL_LOG_DEBUG("direct alignment failed: " << a.failure);
    return false;
  }
  // The prediction's error grows with the frames since the last pose.
  const double n = std::max(1, std::min(s.predicted_frames, s.frames_since_direct));
  const SE3 deviation = a.T_cur_ref * prior.inverse();
  const double max_m = n * s.options.relaxed_max_deviation;
  const double max_rad = n * s.options.relaxed_max_deviation_deg * M_PI / 180.0;
  const SE3 T_ref_cur = a.T_cur_ref.inverse();
  const Matrix6d Ad = T_ref_cur.Adjoint();
  const Matrix6d cov_ref_cur = Ad * a.covariance * Ad.transpose();
  if (deviation.translation().norm() > max_m || deviation.RotationAngle() > max_rad ||
      !s.WithinRelaxedSigma(cov_ref_cur)) {
    PL_LOG_DEBUG("direct alignment refused: " << deviation.translation().norm() << " m, "
                                              << deviation.RotationAngle() * 180.0 / M_PI
                                              << " deg from the prediction");
    return false;
  }
  const SE3 T_w_c = s.T_w_direct * T_ref_cur;
  // The increment from the frame before (r: its predicted pose and increment).
  const SE3 T_w_before = r->T_w_c * r->T_prev_cur.inverse();
  const SE3 T_prev_cur = T_w_before.inverse() * T_w_c;
  if (s.predicted_frames == 1) {  // the frame before had a pose: a measured velocity
    s.velocity_cur_prev = T_prev_cur.inverse();
    s.velocity_valid = true;
  }
  s.MarkTracked(T_w_c, T_prev_cur, cov_ref_cur, r);
  r->direct_aligned = true;
  return true;
}

}  // namespace pl_slam
