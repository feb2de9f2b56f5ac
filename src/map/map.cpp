#include "pl_slam/map/map.h"

#include <algorithm>
#include <sstream>

#include "pl_slam/util/validation.h"

namespace pl_slam {

Eigen::Vector3d LineLandmark::Direction() const {
  const Eigen::Vector3d d = Q_w - P_w;
  const double n = d.norm();
  return n > 0.0 ? Eigen::Vector3d(d / n) : Eigen::Vector3d::Zero();
}

std::string MapOptions::Validate() const {
  std::string err = CheckRange("covisibility_min_shared", covisibility_min_shared, 1, 100000);
  if (err.empty()) err = CheckRange("essential_min_shared", essential_min_shared, 1, 100000);
  return err;
}

Map::Map(const MapOptions& options) : options_(options) {}

uint64_t Map::version() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return version_;
}

MapCounts Map::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapCounts c;
  c.keyframes = keyframes_.size();
  c.points = points_.size();
  c.lines = lines_.size();
  c.culled_keyframes = culled_.size();
  c.culled_points = culled_points_;
  c.culled_lines = culled_lines_;
  return c;
}

void Map::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  keyframes_.clear();
  points_.clear();
  lines_.clear();
  culled_.clear();
  culled_points_ = culled_lines_ = 0;
  keyframes_inserted_ = 0;
  ++version_;
}

MapContents Map::ExportLocked() const {
  MapContents c;
  for (const auto& [id, kf] : keyframes_) c.keyframes[id] = std::make_shared<Keyframe>(*kf);
  for (const auto& [id, p] : points_) {
    auto copy = std::make_shared<PointLandmark>(*p);
    copy->descriptor = p->descriptor.clone();
    c.points[id] = std::move(copy);
  }
  for (const auto& [id, l] : lines_) {
    auto copy = std::make_shared<LineLandmark>(*l);
    copy->descriptor = l->descriptor.clone();
    c.lines[id] = std::move(copy);
  }
  c.culled = culled_;
  c.next_landmark_id = next_landmark_id_;
  c.keyframes_inserted = keyframes_inserted_;
  c.culled_points = culled_points_;
  c.culled_lines = culled_lines_;
  return c;
}

void Map::ReplaceLocked(MapContents&& contents) {
  keyframes_ = std::move(contents.keyframes);
  points_ = std::move(contents.points);
  lines_ = std::move(contents.lines);
  culled_ = std::move(contents.culled);
  next_landmark_id_ = std::max(next_landmark_id_, contents.next_landmark_id);
  keyframes_inserted_ = contents.keyframes_inserted;
  culled_points_ = contents.culled_points;
  culled_lines_ = contents.culled_lines;
  ++version_;
}

std::shared_ptr<Keyframe> Map::KeyframeLocked(KeyframeId id) const {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : it->second;
}
std::shared_ptr<PointLandmark> Map::PointLocked(LandmarkId id) const {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : it->second;
}
std::shared_ptr<LineLandmark> Map::LineLocked(LandmarkId id) const {
  auto it = lines_.find(id);
  return it == lines_.end() ? nullptr : it->second;
}

void Map::AddKeyframeLocked(std::shared_ptr<Keyframe> kf) {
  kf->point_landmarks.assign(kf->features.points.size(), kNoId);
  kf->line_landmarks.assign(kf->features.lines.size(), kNoId);
  keyframes_[kf->id] = std::move(kf);
  ++keyframes_inserted_;
  ++version_;
}

LandmarkId Map::AddPointLocked(const Eigen::Vector3d& p_w, KeyframeId kf_id, int index) {
  const auto kf = KeyframeLocked(kf_id);
  if (!kf || index < 0 || index >= static_cast<int>(kf->point_landmarks.size()) ||
      kf->point_landmarks[index] != kNoId)
    return kNoId;
  auto lm = std::make_shared<PointLandmark>();
  lm->id = next_landmark_id_++;
  lm->p_w = p_w;
  lm->descriptor = kf->features.point_descriptors.row(index).clone();
  lm->octave = kf->features.points[index].octave;
  lm->observations[kf_id] = index;
  lm->reference = kf_id;
  lm->created_at = keyframes_inserted_;
  kf->point_landmarks[index] = lm->id;
  if (index < static_cast<int>(kf->point_offsets.size())) kf->point_offsets[index].setZero();
  points_[lm->id] = lm;
  ++version_;
  return lm->id;
}

LandmarkId Map::AddLineLocked(const Eigen::Vector3d& P_w, const Eigen::Vector3d& Q_w,
                              KeyframeId kf_id, int index) {
  const auto kf = KeyframeLocked(kf_id);
  if (!kf || index < 0 || index >= static_cast<int>(kf->line_landmarks.size()) ||
      kf->line_landmarks[index] != kNoId)
    return kNoId;
  auto lm = std::make_shared<LineLandmark>();
  lm->id = next_landmark_id_++;
  lm->P_w = P_w;
  lm->Q_w = Q_w;
  lm->descriptor = kf->features.line_descriptors.row(index).clone();
  lm->octave = kf->features.lines[index].octave;
  lm->observations[kf_id] = index;
  lm->reference = kf_id;
  lm->created_at = keyframes_inserted_;
  kf->line_landmarks[index] = lm->id;
  lines_[lm->id] = lm;
  ++version_;
  return lm->id;
}

bool Map::AddPointObservationLocked(LandmarkId lm_id, KeyframeId kf_id, int index) {
  const auto kf = KeyframeLocked(kf_id);
  const auto lm = PointLocked(lm_id);
  if (!kf || !lm || index < 0 || index >= static_cast<int>(kf->point_landmarks.size()) ||
      kf->point_landmarks[index] != kNoId || lm->observations.count(kf_id))
    return false;
  lm->observations[kf_id] = index;
  kf->point_landmarks[index] = lm_id;
  // An alignment offset belongs to the landmark it was aligned for.
  if (index < static_cast<int>(kf->point_offsets.size())) kf->point_offsets[index].setZero();
  ++version_;
  return true;
}

bool Map::AddLineObservationLocked(LandmarkId lm_id, KeyframeId kf_id, int index) {
  const auto kf = KeyframeLocked(kf_id);
  const auto lm = LineLocked(lm_id);
  if (!kf || !lm || index < 0 || index >= static_cast<int>(kf->line_landmarks.size()) ||
      kf->line_landmarks[index] != kNoId || lm->observations.count(kf_id))
    return false;
  lm->observations[kf_id] = index;
  kf->line_landmarks[index] = lm_id;
  ++version_;
  return true;
}

void Map::RemovePointObservationLocked(LandmarkId lm_id, KeyframeId kf_id) {
  const auto lm = PointLocked(lm_id);
  if (!lm) return;
  auto it = lm->observations.find(kf_id);
  if (it == lm->observations.end()) return;
  if (const auto kf = KeyframeLocked(kf_id)) {
    kf->point_landmarks[it->second] = kNoId;
    if (it->second < static_cast<int>(kf->point_offsets.size()))
      kf->point_offsets[it->second].setZero();
  }
  lm->observations.erase(it);
  if (lm->observations.empty()) {
    points_.erase(lm_id);
    ++culled_points_;
  }
  ++version_;
}

void Map::RemoveLineObservationLocked(LandmarkId lm_id, KeyframeId kf_id) {
  const auto lm = LineLocked(lm_id);
  if (!lm) return;
  auto it = lm->observations.find(kf_id);
  if (it == lm->observations.end()) return;
  if (const auto kf = KeyframeLocked(kf_id)) kf->line_landmarks[it->second] = kNoId;
  lm->observations.erase(it);
  if (lm->observations.empty()) {
    lines_.erase(lm_id);
    ++culled_lines_;
  }
  ++version_;
}

void Map::ErasePointLocked(LandmarkId lm_id) {
  const auto lm = PointLocked(lm_id);
  if (!lm) return;
  for (const auto& [kf_id, index] : lm->observations)
    if (const auto kf = KeyframeLocked(kf_id)) kf->point_landmarks[index] = kNoId;
  points_.erase(lm_id);
  ++culled_points_;
  ++version_;
}

void Map::EraseLineLocked(LandmarkId lm_id) {
  const auto lm = LineLocked(lm_id);
  if (!lm) return;
  for (const auto& [kf_id, index] : lm->observations)
    if (const auto kf = KeyframeLocked(kf_id)) kf->line_landmarks[index] = kNoId;
  lines_.erase(lm_id);
  ++culled_lines_;
  ++version_;
}

namespace {

/// Moves the observations of `from` to `into` (both in `landmarks`), updating the keyframes'
/// per-feature ids; observations in keyframes already observing `into` are dropped.
template <typename Landmark, typename GetKeyframe, typename Slot>
void MoveObservations(Landmark* from, Landmark* into, GetKeyframe get_keyframe, Slot slot) {
  for (const auto& [kf_id, index] : from->observations) {
    const auto kf = get_keyframe(kf_id);
    if (!kf) continue;
    if (into->observations.count(kf_id)) {
      slot(*kf)[index] = kNoId;
      continue;
    }
    into->observations[kf_id] = index;
    slot(*kf)[index] = into->id;
  }
  from->observations.clear();
}

}  // namespace

bool Map::FusePointLocked(LandmarkId from, LandmarkId into) {
  const auto a = PointLocked(from), b = PointLocked(into);
  if (!a || !b || from == into) return false;
  // Observations aligned to `from`'s patch are not aligned to `into`'s.
  for (const auto& [k, index] : a->observations) {
    const auto kf = KeyframeLocked(k);
    if (kf && index >= 0 && index < static_cast<int>(kf->point_offsets.size()))
      kf->point_offsets[index].setZero();
  }
  MoveObservations(
      a.get(), b.get(), [this](KeyframeId k) { return KeyframeLocked(k); },
      [](Keyframe& kf) -> std::vector<LandmarkId>& { return kf.point_landmarks; });
  points_.erase(from);
  ++culled_points_;
  ++version_;
  return true;
}

bool Map::FuseLineLocked(LandmarkId from, LandmarkId into) {
  const auto a = LineLocked(from), b = LineLocked(into);
  if (!a || !b || from == into) return false;
  MoveObservations(
      a.get(), b.get(), [this](KeyframeId k) { return KeyframeLocked(k); },
      [](Keyframe& kf) -> std::vector<LandmarkId>& { return kf.line_landmarks; });
  lines_.erase(from);
  ++culled_lines_;
  ++version_;
  return true;
}

void Map::EraseKeyframeLocked(KeyframeId id) {
  const auto kf = KeyframeLocked(id);
  if (!kf) return;
  for (LandmarkId lm : std::vector<LandmarkId>(kf->point_landmarks))
    if (lm != kNoId) RemovePointObservationLocked(lm, id);
  for (LandmarkId lm : std::vector<LandmarkId>(kf->line_landmarks))
    if (lm != kNoId) RemoveLineObservationLocked(lm, id);
  // Children hang from the culled keyframe's parent (the tree stays connected).
  const KeyframeId parent = kf->parent;
  for (auto& [other_id, other] : keyframes_)
    if (other->parent == id) other->parent = parent;
  for (KeyframeId loop : kf->loop_edges)
    if (const auto other = KeyframeLocked(loop)) other->loop_edges.erase(id);
  SE3 T_parent_kf = kf->T_w_c;
  if (const auto p = KeyframeLocked(parent)) T_parent_kf = p->T_w_c.inverse() * kf->T_w_c;
  culled_[id] = {parent, T_parent_kf};
  keyframes_.erase(id);
  ++version_;
}

std::vector<std::pair<KeyframeId, int>> Map::CovisibleLocked(KeyframeId id, int min_shared) const {
  std::vector<std::pair<KeyframeId, int>> out;
  const auto kf = KeyframeLocked(id);
  if (!kf) return out;
  std::unordered_map<KeyframeId, int> shared;
  for (LandmarkId lm_id : kf->point_landmarks) {
    if (lm_id == kNoId) continue;
    if (const auto lm = PointLocked(lm_id))
      for (const auto& obs : lm->observations)
        if (obs.first != id) ++shared[obs.first];
  }
  for (LandmarkId lm_id : kf->line_landmarks) {
    if (lm_id == kNoId) continue;
    if (const auto lm = LineLocked(lm_id))
      for (const auto& obs : lm->observations)
        if (obs.first != id) ++shared[obs.first];
  }
  for (const auto& [other, n] : shared)
    if (n >= min_shared) out.emplace_back(other, n);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first > b.first;
  });
  return out;
}

bool Map::KeyframePoseLocked(KeyframeId id, SE3* T_w_c) const {
  SE3 T_acc;  // T_parent_kf chain from the culled keyframe up to a living one
  for (int guard = 0; guard < 100000; ++guard) {
    if (const auto kf = KeyframeLocked(id)) {
      *T_w_c = kf->T_w_c * T_acc;
      return true;
    }
    auto it = culled_.find(id);
    if (it == culled_.end()) return false;
    T_acc = it->second.second * T_acc;
    if (it->second.first == kNoId) {
      *T_w_c = T_acc;
      return true;
    }
    id = it->second.first;
  }
  return false;
}

bool Map::KeyframePose(KeyframeId id, SE3* T_w_c) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return KeyframePoseLocked(id, T_w_c);
}

KeyframeId Map::LastKeyframe() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return keyframes_.empty() ? kNoId : keyframes_.rbegin()->first;
}

LocalMap Map::GetLocalMap(KeyframeId reference, int max_neighbours) const {
  std::lock_guard<std::mutex> lock(mutex_);
  LocalMap local;
  local.reference = reference;
  local.version = version_;
  const auto ref = KeyframeLocked(reference);
  if (!ref) return local;
  std::vector<KeyframeId> kfs{reference};
  const auto covisible = CovisibleLocked(reference, 1);
  for (size_t i = 0; i < covisible.size() && static_cast<int>(i) < max_neighbours; ++i)
    kfs.push_back(covisible[i].first);
  std::set<LandmarkId> seen_points, seen_lines;
  std::vector<cv::Mat> point_rows, line_rows;
  for (KeyframeId kf_id : kfs) {
    const auto kf = KeyframeLocked(kf_id);
    // The reference comes first, so every landmark it observes is listed on this pass.
    const bool is_reference = kf_id == reference;
    for (LandmarkId lm_id : kf->point_landmarks) {
      if (lm_id == kNoId || !seen_points.insert(lm_id).second) continue;
      const auto lm = PointLocked(lm_id);
      if (!lm) continue;
      if (is_reference && lm->observations.size() >= 3) ++local.reference_landmarks;
      PointFeature f;
      f.p_c = lm->p_w;
      f.has_depth = true;
      f.octave = lm->octave;
      local.points.push_back(f);
      local.point_ids.push_back(lm_id);
      point_rows.push_back(lm->descriptor);
    }
    for (LandmarkId lm_id : kf->line_landmarks) {
      if (lm_id == kNoId || !seen_lines.insert(lm_id).second) continue;
      const auto lm = LineLocked(lm_id);
      if (!lm) continue;
      if (is_reference && lm->observations.size() >= 3) ++local.reference_landmarks;
      LineFeature f;
      f.P_c = lm->P_w;
      f.Q_c = lm->Q_w;
      f.has_depth = true;
      f.octave = lm->octave;
      local.lines.push_back(f);
      local.line_ids.push_back(lm_id);
      line_rows.push_back(lm->descriptor);
    }
  }
  if (!point_rows.empty()) cv::vconcat(point_rows, local.point_descriptors);
  if (!line_rows.empty()) cv::vconcat(line_rows, local.line_descriptors);
  return local;
}

MapSnapshot Map::Snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapSnapshot snap;
  snap.version = version_;
  for (const auto& [id, kf] : keyframes_) {
    MapSnapshot::KeyframePose k;
    k.id = id;
    k.frame_index = kf->frame_index;
    k.stamp_s = kf->stamp_s;
    k.T_w_c = kf->T_w_c;
    snap.keyframes.push_back(k);
    for (const auto& [other, n] : CovisibleLocked(id, options_.covisibility_min_shared)) {
      if (other <= id) continue;
      snap.covisibility_edges.emplace_back(id, other);
      if (n > options_.essential_min_shared) snap.essential_edges.emplace_back(id, other);
    }
    if (kf->parent != kNoId)
      snap.essential_edges.emplace_back(std::min(id, kf->parent), std::max(id, kf->parent));
    for (KeyframeId loop : kf->loop_edges)
      if (loop > id) snap.loop_edges.emplace_back(id, loop);
  }
  std::sort(snap.essential_edges.begin(), snap.essential_edges.end());
  snap.essential_edges.erase(std::unique(snap.essential_edges.begin(), snap.essential_edges.end()),
                             snap.essential_edges.end());
  snap.points.reserve(points_.size());
  for (const auto& [id, p] : points_) snap.points.push_back(p->p_w);
  snap.lines.reserve(lines_.size());
  for (const auto& [id, l] : lines_) snap.lines.emplace_back(l->P_w, l->Q_w);
  return snap;
}

}  // namespace pl_slam
