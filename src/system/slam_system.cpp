// The SlamSystem facade over the pipeline modules. Tracking is the point + line stereo
// tracker; mapping and loop closure plug in behind the same interface.
#include "pl_slam/system/slam_system.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <deque>
#include <mutex>

#include "pl_slam/map/map_io.h"
#include "pl_slam/mapping/local_map_matching.h"
#include "pl_slam/system/frame_records.h"
#include "pl_slam/system/odometry.h"
#include "pl_slam/tracking/motion_estimator.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {

const char* TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized:
      return "NOT_INITIALIZED";
    case TrackingState::kTracking:
      return "TRACKING";
    case TrackingState::kLost:
      return "LOST";
  }
  return "UNKNOWN";
}

std::string SystemOptions::Validate() const {
  std::string err = tracker.Validate();
  if (!err.empty()) return "tracker." + err;
  err = mapping.Validate();
  if (!err.empty()) return "mapping." + err;
  err = loop.Validate();
  if (!err.empty()) return "loop." + err;
  return "";
}

namespace {

using Clock = std::chrono::steady_clock;

MappingFrontEnd FrontEndOf(const TrackerOptions& t) {
  MappingFrontEnd f;
  f.point_matching = t.point_matching;
  f.line_matching = t.line_matching;
  f.motion = t.motion;
  f.scale_factor = t.points.scale_factor;
  return f;
}

}  // namespace

struct SlamSystem::Impl {
  StereoCamera camera;
  SystemOptions options;
  std::unique_ptr<StereoTracker> tracker;
  TrackingState state = TrackingState::kNotInitialized;
  SE3 T_w_c;
  // Mapping. Lock order: trajectory_mutex is a leaf; the map's lock is never taken inside it.
  std::unique_ptr<Map> map;
  std::unique_ptr<LoopCloser> loop;  // destroyed after the mapper, which calls it
  std::unique_ptr<LocalMapper> mapper;
  MappingFrontEnd front_end;
  KeyframeId next_keyframe_id = 0;
  KeyframeId reference = kNoId;  // last keyframe handed to mapping
  SE3 T_w_reference;             // its pose as tracking holds it (see FollowMap)
  // Tracking follows what mapping does to the map through the anchor: the newest keyframe it
  // handed over that is already in the map, with its map pose when last looked at. Keyframes
  // handed over but still queued are not in the map yet and cannot show a correction.
  KeyframeId anchor = kNoId;
  SE3 T_w_anchor;
  std::deque<std::pair<KeyframeId, SE3>> pending;  // queued keyframes, poses as tracking holds them

  // A correction of the map (bundle adjustment, loop closure) moves the keyframe poses
  // tracking holds; ApplyCorrection moves the camera too.
  void MoveHeldKeyframes(const SE3& C) {
    T_w_reference = C * T_w_reference;
    for (auto& p : pending) p.second = C * p.second;
  }
  void ApplyCorrection(const SE3& C) {
    if (C.matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-12)) return;
    T_w_c = C * T_w_c;
    MoveHeldKeyframes(C);
    tracker->CorrectPose(T_w_c);
  }

  // Re-anchors to the map: when mapping moved the anchor, the camera moves with it, so tracking
  // continues in the corrected map; a queued keyframe that reached the map (placed there
  // relative to the anchor, then refined) becomes the anchor.
  void FollowMap() {
    SE3 P;
    if (anchor != kNoId && map->KeyframePose(anchor, &P)) {
      ApplyCorrection(P * T_w_anchor.inverse());
      T_w_anchor = P;
    }
    for (std::size_t i = pending.size(); i-- > 0;) {
      if (!map->KeyframePose(pending[i].first, &P)) continue;
      ApplyCorrection(P * pending[i].second.inverse());
      anchor = pending[i].first;
      T_w_anchor = P;
      pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(i) + 1);
      break;
    }
  }

  // This frame's start, after FollowMap: what tracking does from there on is odometry.
  SE3 T_w_start;
  KeyframeId anchor_start = kNoId;
  SE3 T_w_anchor_start;
  bool map_moved = false;  // SettleMapMove's answer for this frame

  // Whether mapping moved the anchor while this frame was tracked. It then depends on the map
  // copy local-map tracking used whether the pose came out in the corrected map or in the old
  // one (`T_w_old`: the pose tracked from the frame's start); tracking carries on in the one
  // the pose is in, so that the next FollowMap does not apply the correction twice.
  bool SettleMapMove(const SE3& T_w_old) {
    SE3 P;
    if (anchor_start == kNoId || !map->KeyframePose(anchor_start, &P) ||
        P.matrix().isApprox(T_w_anchor_start.matrix(), 1e-12))
      return false;
    if (anchor != anchor_start) return true;  // relocalised: tied to the map as it is now
    const SE3 C = P * T_w_anchor_start.inverse();
    auto apart = [](const SE3& a, const SE3& b) {
      const SE3 d = a.inverse() * b;
      return d.translation().norm() + 0.1 * d.RotationAngle();  // 1 deg ~ 1.7 mm
    };
    if (apart(T_w_c, C * T_w_old) < apart(T_w_c, T_w_old)) {
      MoveHeldKeyframes(C);
      T_w_anchor = P;
    }
    return true;
  }

  // Tracking is tied to `id`, a keyframe in the map (relocalisation) or none (reset).
  void AnchorAt(KeyframeId id) {
    reference = anchor = kNoId;
    pending.clear();
    if (id != kNoId && map->KeyframePose(id, &T_w_anchor)) {
      reference = anchor = id;
      T_w_reference = T_w_anchor;
    }
  }
  LocalMap local_map;      // cached copy, refreshed when the map changes
  OdometryChain odometry;  // REP-105 odom: tracked motion only, covariance over time
  int loops_seen = 0;      // loop corrections already reflected in the odometry covariance
  int loops_read = 0;      // loop corrections whose size below was read from the mapper
  double loop_correction_m = 0.0, loop_correction_deg = 0.0;  // the last one's
  std::atomic<bool> localization_only{false};
  bool relocalize_first = false;      // a loaded map: the first pose must come from relocalisation
  mutable std::mutex features_mutex;  // guards last_features (read by the ROS layer)
  StereoFeatures last_features;
  mutable std::mutex trajectory_mutex;  // guards records (read from other threads)
  FrameRecords records;

  void RefreshLocalMap() {
    const KeyframeId last = map->LastKeyframe();
    if (last == kNoId) {
      local_map = LocalMap();
      return;
    }
    if (last == local_map.reference && map->version() == local_map.version) return;
    local_map = map->GetLocalMap(last, options.mapping.local_map_keyframes);
  }
};

SlamSystem::SlamSystem(const StereoCamera& camera, const SystemOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const std::string cam_error = camera.Validate();
  if (!cam_error.empty()) throw ConfigError("camera: " + cam_error);
  const std::string opt_error = options.Validate();
  if (!opt_error.empty()) throw ConfigError(opt_error);
  impl_->camera = camera;
  impl_->options = options;
  // mapping.ba.line_residual=auto: the observed-endpoint form in lines-only mode, where it
  // measured better on every benchmark sequence, the paper's form otherwise.
  std::string& line_residual = impl_->options.mapping.ba.line_residual;
  if (line_residual == "auto")
    line_residual = options.tracker.mode == FeatureMode::kLines ? "observed" : "projected";
  impl_->tracker = std::make_unique<StereoTracker>(camera, options.tracker);
  impl_->front_end = FrontEndOf(options.tracker);
  impl_->map = std::make_unique<Map>(options.mapping.map);
  if (options.mapping.enabled) {
    impl_->mapper = std::make_unique<LocalMapper>(camera, impl_->options.mapping, impl_->front_end,
                                                  impl_->map.get());
    const LoopClosingOptions& lo = options.loop;
    if ((lo.enabled || lo.relocalize) && lo.vocabulary.empty()) {
      PL_LOG_WARN("loop.vocabulary is empty: loop closing and relocalisation are off");
    } else if (lo.enabled || lo.relocalize) {
      impl_->loop =
          std::make_unique<LoopCloser>(camera, lo, impl_->map.get(), options.mapping.threaded);
      if (lo.enabled) impl_->mapper->SetLoopCloser(impl_->loop.get(), lo);
    }
  }
}

SlamSystem::~SlamSystem() {
  impl_->mapper.reset();  // stops the mapping thread before the loop closer and the map go
  impl_->loop.reset();
}

LoopStats SlamSystem::loop_stats() const {
  return impl_->loop ? impl_->loop->stats() : LoopStats();
}

const Map& SlamSystem::map() const { return *impl_->map; }

MappingStats SlamSystem::mapping_stats() const {
  return impl_->mapper ? impl_->mapper->stats() : MappingStats();
}

void SlamSystem::SaveMap(const std::string& path) const { pl_slam::SaveMap(*impl_->map, path); }

void SlamSystem::LoadMap(const std::string& path) {
  Impl& s = *impl_;
  if (!s.mapper) throw ConfigError("mapping.enabled=false: there is no map to load into");
  Map loaded;  // validated completely before the live map is touched
  pl_slam::LoadMap(path, &loaded);
  s.mapper->Clear();
  if (s.loop) s.loop->Clear();
  {
    auto from = loaded.Lock();
    auto to = s.map->Lock();
    s.map->ReplaceLocked(loaded.ExportLocked());
    KeyframeId next = 0;
    for (const auto& [id, kf] : s.map->KeyframesLocked()) next = std::max(next, id + 1);
    // Culled keyframes' ids are not listed: leave a wide gap so new ids never alias them.
    s.next_keyframe_id = std::max(s.next_keyframe_id, next + 1000000);
  }
  if (s.loop) s.loop->IndexMap();
  s.local_map = LocalMap();
  s.AnchorAt(kNoId);
  s.tracker->Reset();
  s.state = TrackingState::kNotInitialized;
  s.relocalize_first = true;
  std::lock_guard<std::mutex> lock(s.trajectory_mutex);
  s.records.clear();
}

void SlamSystem::SetLocalizationOnly(bool on) { impl_->localization_only = on; }
bool SlamSystem::localization_only() const { return impl_->localization_only; }

StereoFeatures SlamSystem::last_features() const {
  std::lock_guard<std::mutex> lock(impl_->features_mutex);
  return impl_->last_features;
}

void SlamSystem::Flush() {
  if (!impl_->mapper) return;
  impl_->mapper->Flush();
  if (impl_->loop) {
    impl_->loop->Flush();    // detection of the last keyframes
    impl_->mapper->Flush();  // and the correction of what it found
  }
}

const StereoCamera& SlamSystem::camera() const { return impl_->camera; }

void SlamSystem::Reset() {
  Impl& s = *impl_;
  if (s.mapper) s.mapper->Clear();
  if (s.loop) s.loop->Clear();
  s.map->Clear();
  s.local_map = LocalMap();
  s.AnchorAt(kNoId);
  s.tracker->Reset();
  s.state = TrackingState::kNotInitialized;
  s.T_w_c = SE3();
  s.odometry.Reset();
  s.loops_seen = s.loops_read = 0;
  s.loop_correction_m = s.loop_correction_deg = 0.0;
  std::lock_guard<std::mutex> lock(s.trajectory_mutex);
  s.records.clear();
}

Trajectory SlamSystem::trajectory() const {
  const Impl& s = *impl_;
  FrameRecords records;
  {
    std::lock_guard<std::mutex> lock(s.trajectory_mutex);
    records = s.records;
  }
  return ResolveTrajectory(
      records, [&](KeyframeId id, SE3* T_w_kf) { return s.map->KeyframePose(id, T_w_kf); },
      s.options.mapping.interpolate_trajectory);
}

FrameResult SlamSystem::Process(const StereoFrame& frame) {
  Impl& s = *impl_;
  const auto t_start = Clock::now();
  FrameResult result;
  result.T_w_c = s.T_w_c;

  result.T_odom_c = s.odometry.T_odom_c();
  result.odom_covariance = s.odometry.covariance();
  const cv::Size expected(s.camera.width, s.camera.height);
  std::string bad;
  if (frame.left.empty() || frame.right.empty())
    bad = "empty image";
  else if (frame.left.type() != CV_8UC1 || frame.right.type() != CV_8UC1)
    bad = "images must be 8-bit single channel";
  else if (frame.left.size() != frame.right.size())
    bad = "left and right image sizes differ";
  else if (frame.left.size() != expected)
    bad = "image size differs from the calibration";
  if (!bad.empty()) {
    PL_LOG_WARN("frame " << frame.index << ": " << bad << "; frame skipped, tracking lost");
    if (s.state != TrackingState::kNotInitialized) s.state = TrackingState::kLost;
    result.state = s.state;
    result.warning = bad;
    result.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
    return result;
  }

  if (s.mapper) s.FollowMap();
  // What tracking does to the pose from here on is odometry; the corrections above are not.
  s.T_w_start = s.T_w_c;
  s.anchor_start = s.anchor;
  s.T_w_anchor_start = s.T_w_anchor;
  s.map_moved = false;

  // Keyframes whenever local mapping can take them (tracker.keyframes.idle_min_frames); the
  // mapper's lock is only taken when that rule is on.
  const bool mapping_idle = s.mapper && !s.localization_only &&
                            s.options.tracker.keyframes.idle_min_frames > 0 && s.mapper->Idle();
  TrackerResult r = s.tracker->Track(frame, mapping_idle);
  {
    std::lock_guard<std::mutex> lock(s.features_mutex);
    s.last_features = s.tracker->last_features();
  }
  if (s.relocalize_first && r.pose_valid) {
    // A loaded map: the tracker's own initialisation (at the identity) is not a pose in it.
    r.pose_valid = false;
    r.state = TrackerState::kLost;
    r.is_keyframe = false;
    r.warning = "waiting to relocalise in the loaded map";
  }
  // (last_features() are this frame's only when it had some with depth.)
  if (!r.pose_valid && r.state == TrackerState::kLost && !s.relocalize_first && s.mapper &&
      s.options.mapping.track_local_map && r.points_stereo + r.lines_stereo > 0 &&
      s.map->LastKeyframe() != kNoId) {
    // Before the frame is given up: the local map (points and segments), searched around the
    // motion model's prediction.
    const auto t0 = Clock::now();
    s.RefreshLocalMap();
    if (!s.local_map.point_ids.empty() || !s.local_map.line_ids.empty()) {
      // While the pose follows the motion model, the tracker's relaxed gate applies: fewer
      // inliers, when the estimate is tight and lands near the prediction.
      const TrackerOptions& to = s.options.tracker;
      const bool relaxed = r.predicted && to.relaxed_min_inliers > 0 &&
                           to.relaxed_min_inliers < s.options.mapping.track_min_inliers;
      LocalMapGate gate = LocalMapGate::Of(s.options.mapping);
      if (relaxed) {
        gate.min_inliers = to.relaxed_min_inliers;
        gate.max_correction = std::max(gate.max_correction, to.relaxed_max_deviation);
        gate.max_correction_deg = std::max(gate.max_correction_deg, to.relaxed_max_deviation_deg);
      }
      const LocalMapTracking rescue =
          TrackLocalMap(s.camera, s.tracker->last_features(), s.local_map, r.T_w_c,
                        s.options.mapping, s.front_end, &gate);
      const int inliers = rescue.point_inliers + rescue.line_inliers;
      const SE3 correction = r.T_w_c.inverse() * rescue.T_w_c;
      const bool strict =
          inliers >= std::max(to.min_inliers, s.options.mapping.track_min_inliers) &&
          correction.translation().norm() <= s.options.mapping.track_max_correction &&
          correction.RotationAngle() * 180.0 / M_PI <= s.options.mapping.track_max_correction_deg;
      if (rescue.success &&
          (strict || (relaxed && SigmaWithin(rescue.covariance, to.relaxed_max_deviation,
                                             to.relaxed_max_deviation_deg * M_PI / 180.0)))) {
        s.tracker->Rescued(rescue.T_w_c);
        r.pose_valid = true;
        r.state = TrackerState::kTracking;
        r.T_w_c = rescue.T_w_c;
        r.predicted = false;
        r.is_keyframe = false;
        r.warning.clear();
        result.map_rescued = true;
        PL_LOG_DEBUG("frame " << frame.index << ": visual odometry lost, the local map held ("
                              << rescue.point_inliers << " point and " << rescue.line_inliers
                              << " line inliers)");
      } else {
        PL_LOG_DEBUG("frame " << frame.index << ": the local map did not hold either ("
                              << (rescue.success ? "estimate not tight enough" : rescue.failure)
                              << ")");
      }
    }
    r.stage_ms.emplace_back("rescue",
                            std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  if (!r.pose_valid && r.predicted && !s.relocalize_first && s.tracker->TrackDirect(frame, &r)) {
    // Features too few for the frame and the local map: the image's edges still hold it.
    result.direct_aligned = true;
    PL_LOG_DEBUG("frame " << frame.index << ": features too few, direct alignment held");
  }
  if (!r.pose_valid && !s.relocalize_first && s.tracker->TrackFused(frame, &r)) {
    // A few clustered matches: with the motion model as a prior they still hold.
    result.prior_fused = true;
    PL_LOG_DEBUG("frame " << frame.index << ": features too few alone, with the motion model "
                          << "they held (" << r.point_inliers << " point and " << r.line_inliers
                          << " line inliers of " << r.point_matches << " and " << r.line_matches
                          << " matches)");
  }
  if (!r.pose_valid && s.loop && s.options.loop.relocalize &&
      r.points_stereo + r.lines_stereo > 0 && s.map->LastKeyframe() != kNoId) {
    // Lost: look for the place in the map before restarting from the last pose.
    SE3 T_w_c;
    KeyframeId kf = kNoId;
    if (s.loop->Relocalize(s.tracker->last_features(), &T_w_c, &kf)) {
      s.tracker->Relocalized(T_w_c);
      r.pose_valid = true;
      r.state = TrackerState::kTracking;
      r.T_w_c = T_w_c;
      r.is_keyframe = false;
      r.warning.clear();
      result.relocalized = true;
      s.AnchorAt(kf);
      s.relocalize_first = false;
      PL_LOG_INFO("frame " << frame.index << ": relocalised against keyframe " << kf);
    }
  }
  const TrackingState previous = s.state;
  s.state = static_cast<TrackingState>(r.state);
  if (!r.warning.empty() &&
      (r.state == TrackerState::kLost && previous == TrackingState::kTracking)) {
    PL_LOG_WARN("frame " << frame.index << ": tracking lost (" << r.warning
                         << "); restarting from the last pose");
  } else if (!r.warning.empty() && r.state != TrackerState::kTracking) {
    PL_LOG_DEBUG("frame " << frame.index << ": " << r.warning);
  } else if (r.state == TrackerState::kTracking && previous == TrackingState::kLost) {
    PL_LOG_INFO("frame " << frame.index << ": tracking recovered");
  }
  s.T_w_c = r.T_w_c;
  result.state = s.state;
  result.T_w_c = r.T_w_c;
  result.pose_valid = r.pose_valid;
  result.predicted = r.predicted;
  result.covariance = r.covariance_prev_cur;
  result.is_keyframe = r.is_keyframe;
  result.points_detected = r.points_detected;
  result.lines_detected = r.lines_detected;
  result.points_stereo = r.points_stereo;
  result.lines_stereo = r.lines_stereo;
  result.point_matches = r.point_matches;
  result.line_matches = r.line_matches;
  result.point_inliers = r.point_inliers;
  result.line_inliers = r.line_inliers;
  result.warning = r.warning;
  result.stage_ms = r.stage_ms;
  if (s.mapper) TrackAndMap(frame, r, &result);
  // A bundle adjustment or loop correction the mapping thread applied while this frame was
  // tracked may have reached the local-map refinement: the pose difference would then carry
  // part of a correction, so the odometry takes the tracker's own increment instead.
  AdvanceOdometry(s.T_w_start, r, s.map_moved, &result);
  if (result.pose_valid) {
    std::lock_guard<std::mutex> lock(s.trajectory_mutex);
    FrameRecord rec;
    rec.stamp_s = frame.stamp_s();
    rec.stamp_ns = frame.stamp_ns;
    rec.T_w_c = result.T_w_c;
    rec.reference = s.reference;
    rec.T_ref_c = s.T_w_reference.inverse() * result.T_w_c;
    s.records.push_back(rec);
  }
  result.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
  return result;
}

void SlamSystem::AdvanceOdometry(const SE3& T_w_before, const TrackerResult& r, bool map_moved,
                                 FrameResult* result) {
  Impl& s = *impl_;
  if (!result->relocalized) {
    // The tracked (or, while lost, predicted) motion of this frame, local-map refinement
    // included. A relocalisation jump is no motion: odom holds and map -> odom takes it.
    result->T_prev_cur =
        map_moved && (r.pose_valid || r.predicted) ? r.T_prev_cur : T_w_before.inverse() * s.T_w_c;
    // While lost the uncertainty grows on every frame, also where the pose only stays (the
    // camera moved unseen; TrackerResult::covariance_prev_cur), with the gap's length
    // (OdometryChain::Advance).
    const bool unseen = !result->pose_valid && r.state == TrackerState::kLost;
    s.odometry.Advance(result->T_prev_cur,
                       result->pose_valid || unseen ? result->covariance : Matrix6d::Zero(),
                       unseen);
  }
  if (result->relocalized || result->loops > s.loops_seen) {
    // The pose is tied to the map again: its uncertainty is that of one tracked increment
    // (a relocalisation's: 1 cm and 0.5 deg).
    Matrix6d tied = Matrix6d::Zero();
    const double deg = M_PI / 180.0;
    tied.diagonal() << 1e-4, 1e-4, 1e-4, 0.25 * deg * deg, 0.25 * deg * deg, 0.25 * deg * deg;
    s.odometry.SetCovariance(result->pose_valid && !result->relocalized ? r.covariance_prev_cur
                                                                        : tied);
    s.loops_seen = result->loops;
  }
  result->T_odom_c = s.odometry.T_odom_c();
  result->odom_covariance = s.odometry.covariance();
}

void SlamSystem::TrackAndMap(const StereoFrame& frame, const TrackerResult& r,
                             FrameResult* result) {
  Impl& s = *impl_;
  const auto t0 = Clock::now();
  const MappingOptions& mo = s.options.mapping;
  LocalMapTracking tracked;
  if (r.pose_valid && mo.track_local_map) {
    s.RefreshLocalMap();
    if (!s.local_map.point_ids.empty() || !s.local_map.line_ids.empty()) {
      tracked = TrackLocalMap(s.camera, s.tracker->last_features(), s.local_map, r.T_w_c, mo,
                              s.front_end);
      const int vo_inliers = r.point_inliers + r.line_inliers;
      if (tracked.success &&
          tracked.point_inliers + tracked.line_inliers < mo.track_min_inlier_ratio * vo_inliers) {
        tracked.success = false;
        tracked.failure = "fewer local-map inliers than visual odometry's";
      }
      if (tracked.success) {
        s.tracker->CorrectPose(tracked.T_w_c);
        s.T_w_c = tracked.T_w_c;
        result->T_w_c = tracked.T_w_c;
        result->map_tracked = true;
        result->map_point_inliers = tracked.point_inliers;
        result->map_line_inliers = tracked.line_inliers;
      } else {
        PL_LOG_DEBUG("frame " << frame.index << ": " << tracked.failure);
      }
    }
  }
  s.map_moved = s.SettleMapMove(s.T_w_start * r.T_prev_cur);
  result->stage_ms.emplace_back(
      "local_map", std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  if (result->is_keyframe && tracked.success && mo.skip_covered_keyframes > 0.0 &&
      s.local_map.reference_landmarks > 0 &&
      (r.keyframe_reason == KeyframeReason::kEntropy ||
       r.keyframe_reason == KeyframeReason::kLargeMotion ||
       r.keyframe_reason == KeyframeReason::kMaxFrames ||
       r.keyframe_reason == KeyframeReason::kMappingIdle) &&
      tracked.point_inliers + tracked.line_inliers >=
          mo.skip_covered_keyframes * s.local_map.reference_landmarks) {
    result->is_keyframe = false;
    result->keyframe_skipped = true;
  }
  if (result->is_keyframe && r.pose_valid && !s.localization_only) {
    KeyframeInput kf;
    kf.id = s.next_keyframe_id++;
    kf.frame_index = frame.index;
    kf.stamp_s = frame.stamp_s();
    kf.T_w_c = result->T_w_c;
    kf.anchor = s.anchor;
    kf.T_w_anchor = s.T_w_anchor;
    kf.features = s.tracker->last_features();
    if (s.options.mapping.align_points) kf.left_image = frame.left.clone();
    if (tracked.success) {
      kf.point_associations = tracked.point_associations;
      kf.line_associations = tracked.line_associations;
    }
    const KeyframeId id = kf.id;
    if (s.mapper->Submit(std::move(kf))) {
      s.reference = id;
      s.T_w_reference = result->T_w_c;
      s.pending.emplace_back(id, result->T_w_c);
    } else {
      PL_LOG_DEBUG("frame " << frame.index << ": mapping busy, keyframe dropped");
    }
  }
  result->loops = s.mapper->loop_corrections();
  if (result->loops != s.loops_read) {  // the mapper sets the size before it counts the loop
    const SE3 c = s.mapper->last_loop_correction();
    s.loop_correction_m = c.translation().norm();
    s.loop_correction_deg = c.RotationAngle() * 180.0 / M_PI;
    s.loops_read = result->loops;
  }
  result->loop_correction_m = s.loop_correction_m;
  result->loop_correction_deg = s.loop_correction_deg;
  const MapCounts counts = s.map->counts();
  result->keyframes = static_cast<int>(counts.keyframes);
  result->map_points = static_cast<int>(counts.points);
  result->map_lines = static_cast<int>(counts.lines);
}

}  // namespace pl_slam
