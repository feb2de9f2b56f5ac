// Keyframe insertion: refine the pose against the previous keyframe, then give the keyframe's
// features observations of existing landmarks before creating new ones, so that one physical
// point or segment stays one landmark.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <unordered_set>

#include "mapping_steps.h"
#include "pl_slam/mapping/local_map_matching.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace mapping {

bool TriangulateLine(const StereoCamera& cam, const SE3& T_w_a, const LineFeature& a,
                     const SE3& T_w_b, const LineFeature& b, double min_angle_rad, double max_depth,
                     Eigen::Vector3d* P_w, Eigen::Vector3d* Q_w) {
  constexpr double kMinDepth = 0.1;  // metres
  // Image line l (l . (u, v, 1) = 0) -> plane through the centre with normal K^T l.
  auto normal = [&](const LineFeature& f) {
    return Eigen::Vector3d(f.l(0) * cam.fx, f.l(1) * cam.fy,
                           f.l(0) * cam.cx + f.l(1) * cam.cy + f.l(2))
        .normalized();
  };
  const Eigen::Vector3d na = T_w_a.rotation() * normal(a);
  const Eigen::Vector3d nb = T_w_b.rotation() * normal(b);
  if (na.cross(nb).norm() < std::sin(min_angle_rad)) return false;
  const Eigen::Vector3d Ca = T_w_a.translation(), Cb = T_w_b.translation();
  auto cast = [&](const Eigen::Vector2d& uv, Eigen::Vector3d* X) {
    const Eigen::Vector3d d = T_w_b.rotation() * Eigen::Vector3d((uv.x() - cam.cx) / cam.fx,
                                                                 (uv.y() - cam.cy) / cam.fy, 1.0);
    const double denom = na.dot(d);
    if (std::abs(denom) < 1e-12) return false;
    const double z = na.dot(Ca - Cb) / denom;  // depth in view b (the ray has z = 1)
    if (!(z >= kMinDepth && z <= max_depth)) return false;
    *X = Cb + z * d;
    return true;
  };
  if (!cast(b.s, P_w) || !cast(b.e, Q_w)) return false;
  const SE3 T_a_w = T_w_a.inverse();
  const Eigen::Vector3d Pa = T_a_w * *P_w, Qa = T_a_w * *Q_w;
  if (Pa.z() < kMinDepth || Qa.z() < kMinDepth || Pa.z() > max_depth || Qa.z() > max_depth)
    return false;
  // The same stretch of line in both views: half of the shorter extent shared along a.
  const Eigen::Vector2d u = (a.e - a.s) / a.length;
  const double t1 = u.dot(cam.Project(Pa) - a.s), t2 = u.dot(cam.Project(Qa) - a.s);
  const double shared = std::min(std::max(t1, t2), a.length) - std::max(std::min(t1, t2), 0.0);
  return shared >= 0.5 * std::min(a.length, std::abs(t2 - t1));
}

namespace {

/// World positions of the previous keyframe's features: its landmark's when it has one, else
/// its own stereo triangulation.
struct PreviousKeyframe {
  std::shared_ptr<const Keyframe> kf;
  SE3 T_w_c;
  std::vector<char> point_valid, line_valid;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> point_w, line_P_w,
      line_Q_w;
};

bool CopyPrevious(const Context& ctx, PreviousKeyframe* prev) {
  Map& map = *ctx.map;
  auto lock = map.Lock();
  const auto& kfs = map.KeyframesLocked();
  if (kfs.empty()) return false;
  const auto& kf = kfs.rbegin()->second;
  prev->kf = kf;
  prev->T_w_c = kf->T_w_c;
  const StereoFeatures& f = kf->features;
  prev->point_valid.assign(f.points.size(), 0);
  prev->point_w.assign(f.points.size(), Eigen::Vector3d::Zero());
  for (size_t i = 0; i < f.points.size(); ++i) {
    if (const auto lm = map.PointLocked(kf->point_landmarks[i])) {
      prev->point_w[i] = lm->p_w;
      prev->point_valid[i] = 1;
    } else if (f.points[i].has_depth) {
      prev->point_w[i] = kf->T_w_c * f.points[i].p_c;
      prev->point_valid[i] = 1;
    }
  }
  prev->line_valid.assign(f.lines.size(), 0);
  prev->line_P_w.assign(f.lines.size(), Eigen::Vector3d::Zero());
  prev->line_Q_w.assign(f.lines.size(), Eigen::Vector3d::Zero());
  for (size_t i = 0; i < f.lines.size(); ++i) {
    if (const auto lm = map.LineLocked(kf->line_landmarks[i])) {
      prev->line_P_w[i] = lm->P_w;
      prev->line_Q_w[i] = lm->Q_w;
      prev->line_valid[i] = 1;
    } else if (f.lines[i].has_depth) {
      prev->line_P_w[i] = kf->T_w_c * f.lines[i].P_c;
      prev->line_Q_w[i] = kf->T_w_c * f.lines[i].Q_c;
      prev->line_valid[i] = 1;
    }
  }
  return true;
}

/// Matches the new keyframe against the previous one and refines its pose from the previous
/// keyframe's 3D features; keeps only the inlier matches. Line matches where neither segment
/// has a 3D position (no landmark, no stereo depth) go to `depthless_matches`. When the
/// estimate is not used (too few inliers, too large a correction, refinement off), a match is kept
/// only if it also fits the tracked pose: an estimate that fails may have bent to fit a wrong
/// match.
void RefineAgainstPrevious(const Context& ctx, const PreviousKeyframe& prev, Keyframe* kf,
                           std::vector<std::pair<int, int>>* point_matches,
                           std::vector<std::pair<int, int>>* line_matches,
                           std::vector<std::pair<int, int>>* depthless_matches) {
  const StereoFeatures& pf = prev.kf->features;
  const StereoFeatures& cf = kf->features;
  const SE3 T_new_prev = kf->T_w_c.inverse() * prev.T_w_c;
  std::vector<std::pair<int, int>> pm_all, lm_all;
  if (!pf.points.empty() && !cf.points.empty())
    pm_all =
        MatchPointsFrameToFrame(ctx.camera, pf.points, pf.point_descriptors, cf.points,
                                cf.point_descriptors, ctx.front_end.point_matching, &T_new_prev);
  if (!pf.lines.empty() && !cf.lines.empty()) {
    LinePrediction prediction;
    prediction.T_cur_prev = T_new_prev;
    prediction.camera = ctx.camera;
    lm_all = MatchLines(pf.lines, pf.line_descriptors, cf.lines, cf.line_descriptors,
                        ctx.front_end.line_matching, &prediction);
  }
  PointMatches3D2D pm;
  LineMatches3D2D lm;
  std::vector<std::pair<int, int>> pm_used, lm_used;
  for (const auto& [i, j] : pm_all) {
    if (!prev.point_valid[i]) continue;
    PointMatch3D2D m;
    m.P_prev = prev.point_w[i];
    m.uv_cur = cf.points[j].uv;
    const double s = PointSqrtInfo(ctx, cf.points[j].octave);
    m.weight = s * s;
    m.u_right_cur = cf.points[j].u_right();
    pm.push_back(m);
    pm_used.emplace_back(i, j);
  }
  for (const auto& [i, j] : lm_all) {
    if (!prev.line_valid[i]) {
      if (!cf.lines[j].has_depth) depthless_matches->emplace_back(i, j);
      continue;
    }
    LineMatch3D2D m;
    m.P_prev = prev.line_P_w[i];
    m.Q_prev = prev.line_Q_w[i];
    m.l_cur = cf.lines[j].l;
    m.weight = ctx.options.line_weight;
    lm.push_back(m);
    lm_used.emplace_back(i, j);
  }
  // The "previous frame" of the estimator is the world here: it estimates T_new_w.
  const MotionEstimate est =
      EstimateMotion(ctx.camera, pm, lm, kf->T_w_c.inverse(), ctx.front_end.motion);
  if (!est.success) return;  // no reliable matches: tracking's pose and associations only
  const SE3 T_w_new = est.T_cur_prev.inverse();
  const SE3 correction = T_w_new.inverse() * kf->T_w_c;
  const bool trusted = ctx.options.refine_against_previous &&
                       est.point_inliers + est.line_inliers >= ctx.options.refine_min_inliers &&
                       T_w_new.IsFinite() &&
                       correction.translation().norm() < ctx.options.refine_max_correction &&
                       correction.RotationAngle() < 0.1;
  // At the tracked pose, a match within the estimator's widest outlier gate fits.
  const SE3 T_track = kf->T_w_c.inverse();
  const MotionEstimatorOptions& mo = ctx.front_end.motion;
  const double gate2 = mo.outlier_max_px * mo.outlier_max_px;
  auto fits = [&](double weight, const Eigen::Vector2d& r) {
    return weight * r.squaredNorm() <= gate2;
  };
  Eigen::Vector2d r;
  for (size_t k = 0; k < pm_used.size(); ++k)
    if (est.point_inlier[k] &&
        (trusted || (PointResidualAndJacobian(ctx.camera, T_track, pm[k].P_prev, pm[k].uv_cur,
                                              mo.min_depth, &r, nullptr) &&
                     fits(pm[k].weight, r))))
      point_matches->push_back(pm_used[k]);
  for (size_t k = 0; k < lm_used.size(); ++k)
    if (est.line_inlier[k] &&
        (trusted || (LineResidualAndJacobian(ctx.camera, T_track, lm[k].P_prev, lm[k].Q_prev,
                                             lm[k].l_cur, mo.min_depth, &r, nullptr) &&
                     fits(lm[k].weight, r))))
      line_matches->push_back(lm_used[k]);
  if (trusted) kf->T_w_c = T_w_new;
}

/// Projects the local map's landmarks that the keyframe does not observe yet into it and
/// matches them with its features that have no landmark; adds the observations.
void SearchLocalMap(const Context& ctx, Keyframe* kf) {
  Map& map = *ctx.map;
  const LocalMap local = map.GetLocalMap(kf->id, ctx.options.local_map_keyframes);
  // Only this thread changes the keyframe's landmark vectors: reading them unlocked is safe.
  const std::unordered_set<LandmarkId> own_points(kf->point_landmarks.begin(),
                                                  kf->point_landmarks.end());
  const std::unordered_set<LandmarkId> own_lines(kf->line_landmarks.begin(),
                                                 kf->line_landmarks.end());
  LocalMapMasks masks;
  for (LandmarkId id : local.point_ids) masks.skip_local_points.push_back(own_points.count(id));
  for (LandmarkId id : local.line_ids) masks.skip_local_lines.push_back(own_lines.count(id));
  for (LandmarkId id : kf->point_landmarks) masks.skip_feature_points.push_back(id != kNoId);
  for (LandmarkId id : kf->line_landmarks) masks.skip_feature_lines.push_back(id != kNoId);
  const LocalMapMatches matches =
      MatchLocalMap(ctx.camera, local, kf->T_w_c.inverse(), kf->features, masks, ctx.front_end,
                    ctx.options.search_radius);
  auto lock = map.Lock();
  for (const auto& [i, j] : matches.points)
    map.AddPointObservationLocked(local.point_ids[i], kf->id, j);
  for (const auto& [i, j] : matches.lines)
    map.AddLineObservationLocked(local.line_ids[i], kf->id, j);
}

/// Fuses duplicated landmarks: the local map's landmarks that the keyframe does not observe are
/// projected into it and matched with its features that already have a landmark. Such a
/// match is one physical point or segment mapped twice (a revisit tracked without a loop
/// closure, a feature the local-map search missed); the landmark with fewer observations is
/// merged into the other, provided the two agree in 3D. Without this, every revisit adds a
/// copy of what it sees, and keyframes holding copies never become redundant.
void FuseDuplicates(const Context& ctx, Keyframe* kf) {
  Map& map = *ctx.map;
  const LocalMap local = map.GetLocalMap(kf->id, ctx.options.local_map_keyframes);
  LocalMapMasks masks;
  std::unordered_set<LandmarkId> own_points, own_lines;
  {
    auto lock = map.Lock();
    own_points.insert(kf->point_landmarks.begin(), kf->point_landmarks.end());
    own_lines.insert(kf->line_landmarks.begin(), kf->line_landmarks.end());
    for (LandmarkId id : kf->point_landmarks) masks.skip_feature_points.push_back(id == kNoId);
    for (LandmarkId id : kf->line_landmarks) masks.skip_feature_lines.push_back(id == kNoId);
  }
  for (LandmarkId id : local.point_ids) masks.skip_local_points.push_back(own_points.count(id));
  for (LandmarkId id : local.line_ids) masks.skip_local_lines.push_back(own_lines.count(id));
  const LocalMapMatches matches =
      MatchLocalMap(ctx.camera, local, kf->T_w_c.inverse(), kf->features, masks, ctx.front_end,
                    ctx.options.search_radius);
  const Eigen::Vector3d centre = kf->T_w_c.translation();
  // Same place in 3D: within 5% of the distance to the camera plus 2 cm (stereo depth noise).
  auto close = [&](const Eigen::Vector3d& a, double distance_to_b) {
    return distance_to_b <= 0.05 * (a - centre).norm() + 0.02;
  };
  auto lock = map.Lock();
  for (const auto& [i, j] : matches.points) {
    const LandmarkId other = local.point_ids[i], mine = kf->point_landmarks[j];
    const auto a = map.PointLocked(other), b = map.PointLocked(mine);
    if (!a || !b || other == mine || !close(b->p_w, (a->p_w - b->p_w).norm())) continue;
    if (a->observations.size() >= b->observations.size())
      map.FusePointLocked(mine, other);
    else
      map.FusePointLocked(other, mine);
  }
  for (const auto& [i, j] : matches.lines) {
    const LandmarkId other = local.line_ids[i], mine = kf->line_landmarks[j];
    const auto a = map.LineLocked(other), b = map.LineLocked(mine);
    if (!a || !b || other == mine) continue;
    // b's midpoint must lie near a's infinite line.
    const Eigen::Vector3d mid = 0.5 * (b->P_w + b->Q_w), d = a->Direction();
    if (d.isZero()) continue;
    const Eigen::Vector3d off = (mid - a->P_w) - d * d.dot(mid - a->P_w);
    if (!close(mid, off.norm())) continue;
    if (a->observations.size() >= b->observations.size())
      map.FuseLineLocked(mine, other);
    else
      map.FuseLineLocked(other, mine);
  }
}

/// Caller holds the map lock. Extends the line tracks with the new keyframe's matches to the
/// previous one (segments neither has a 3D position for) and triangulates each track between
/// its first keyframe and the new one once they see it from far enough apart (consecutive
/// keyframes at walking speed rarely do): the landmark is observed in both.
void TriangulateDepthlessLines(const Context& ctx, const Keyframe& prev,
                               const std::vector<std::pair<int, int>>& depthless_matches,
                               Keyframe* kf) {
  constexpr KeyframeId kTrackKeyframes = 30;  // tracks older than this many keyframes end
  const double min_angle = ctx.options.line_triangulation_min_angle_deg * M_PI / 180.0;
  if (!ctx.line_tracks || min_angle <= 0.0) return;
  Map& map = *ctx.map;
  LineTracks& tracks = *ctx.line_tracks;
  for (auto it = tracks.begin(); it != tracks.end();)
    it = it->first + kTrackKeyframes < kf->id ? tracks.erase(it) : std::next(it);
  const std::pair<KeyframeId, int> none(kNoId, -1);
  auto& mine = tracks[kf->id];
  mine.assign(kf->features.lines.size(), none);
  const auto prev_tracks = tracks.find(prev.id);
  const double max_depth =
      ctx.options.line_triangulation_max_depth_baselines * std::abs(ctx.camera.baseline);
  for (const auto& [i, j] : depthless_matches) {
    if (kf->line_landmarks[j] != kNoId || prev.line_landmarks[i] != kNoId) continue;
    std::pair<KeyframeId, int> origin(prev.id, i);
    if (prev_tracks != tracks.end() && prev_tracks->second[i] != none)
      origin = prev_tracks->second[i];
    const auto first = map.KeyframeLocked(origin.first);
    if (!first || first->line_landmarks[origin.second] != kNoId) continue;
    Eigen::Vector3d P_w, Q_w;
    if (TriangulateLine(ctx.camera, first->T_w_c, first->features.lines[origin.second], kf->T_w_c,
                        kf->features.lines[j], min_angle, max_depth, &P_w, &Q_w)) {
      const LandmarkId lm = map.AddLineLocked(P_w, Q_w, first->id, origin.second);
      if (lm != kNoId) map.AddLineObservationLocked(lm, kf->id, j);
    } else {
      mine[j] = origin;  // not yet: the track goes on
    }
  }
}

}  // namespace

void InsertKeyframe(const Context& ctx, KeyframeInput* input) {
  Map& map = *ctx.map;
  auto kf = std::make_shared<Keyframe>();
  kf->id = input->id;
  kf->frame_index = input->frame_index;
  kf->stamp_s = input->stamp_s;
  kf->T_w_c = input->T_w_c;
  SE3 T_w_anchor_now;
  if (input->anchor != kNoId && map.KeyframePose(input->anchor, &T_w_anchor_now))
    kf->T_w_c = T_w_anchor_now * input->T_w_anchor.inverse() * input->T_w_c;
  kf->features = std::move(input->features);

  PreviousKeyframe prev;
  std::vector<std::pair<int, int>> point_matches, line_matches, depthless_matches;
  const bool has_prev = CopyPrevious(ctx, &prev);
  if (has_prev)
    RefineAgainstPrevious(ctx, prev, kf.get(), &point_matches, &line_matches, &depthless_matches);

  {
    auto lock = map.Lock();
    kf->parent = has_prev ? prev.kf->id : kNoId;
    map.AddKeyframeLocked(kf);
    for (const auto& [j, lm] : input->point_associations)
      map.AddPointObservationLocked(lm, kf->id, j);
    for (const auto& [j, lm] : input->line_associations)
      map.AddLineObservationLocked(lm, kf->id, j);
    if (has_prev && map.KeyframeLocked(prev.kf->id)) {
      const auto& pk = *prev.kf;
      for (const auto& [i, j] : point_matches) {
        if (kf->point_landmarks[j] != kNoId) continue;
        LandmarkId lm = pk.point_landmarks[i];
        if (lm == kNoId && pk.features.points[i].has_depth)
          lm = map.AddPointLocked(pk.T_w_c * pk.features.points[i].p_c, pk.id, i);
        if (lm != kNoId) map.AddPointObservationLocked(lm, kf->id, j);
      }
      for (const auto& [i, j] : line_matches) {
        if (kf->line_landmarks[j] != kNoId) continue;
        LandmarkId lm = pk.line_landmarks[i];
        const LineFeature& pl = pk.features.lines[i];
        if (lm == kNoId && pl.has_depth)
          lm = map.AddLineLocked(pk.T_w_c * pl.P_c, pk.T_w_c * pl.Q_c, pk.id, i);
        if (lm != kNoId) map.AddLineObservationLocked(lm, kf->id, j);
      }
      TriangulateDepthlessLines(ctx, pk, depthless_matches, kf.get());
    }
  }

  SearchLocalMap(ctx, kf.get());

  auto lock = map.Lock();
  const StereoFeatures& f = kf->features;
  for (size_t j = 0; j < f.points.size(); ++j)
    if (f.points[j].has_depth && kf->point_landmarks[j] == kNoId)
      map.AddPointLocked(kf->T_w_c * f.points[j].p_c, kf->id, static_cast<int>(j));
  for (size_t j = 0; j < f.lines.size(); ++j)
    if (f.lines[j].has_depth && kf->line_landmarks[j] == kNoId)
      map.AddLineLocked(kf->T_w_c * f.lines[j].P_c, kf->T_w_c * f.lines[j].Q_c, kf->id,
                        static_cast<int>(j));
  if (ctx.options.fuse_duplicates) {
    lock.unlock();
    FuseDuplicates(ctx, kf.get());
    lock.lock();
  }
  // Spanning tree: hang the keyframe from the one it shares most landmarks with.
  const auto covisible = map.CovisibleLocked(kf->id, 1);
  if (!covisible.empty()) kf->parent = covisible.front().first;
  map.TouchLocked();
  lock.unlock();
  if (ctx.options.align_points && !input->left_image.empty())
    AlignPointObservations(ctx, kf.get(), input->left_image);
}

}  // namespace mapping
}  // namespace pl_slam
