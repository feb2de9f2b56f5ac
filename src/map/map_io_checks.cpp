// Consistency checks of map contents before they are written or after they are read: a
// file whose checksum is right may still describe a map the Map could not have built.
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "map_io_internal.h"

namespace pl_slam {
namespace map_io_internal {
namespace {

template <typename Vector>
bool Finite(const Vector& v) {
  return v.allFinite();
}

bool GoodDescriptors(const cv::Mat& d, size_t rows) {
  return rows == 0 || (d.type() == CV_8U && d.cols == kDescriptorBytes &&
                       d.rows == static_cast<int>(rows) && d.dims == 2);
}

bool GoodLandmarkDescriptor(const cv::Mat& d) {
  return d.type() == CV_8U && d.rows == 1 && d.cols == kDescriptorBytes && d.isContinuous();
}

}  // namespace

/// Throws FormatError("is invalid: ...") unless `c` is a map the Map could have built: finite
/// numbers, 32-byte descriptors, observations and keyframe landmark ids agreeing both ways, ids
/// below the counters, spanning tree and culled chains without cycles.
void ValidateContents(const MapContents& c) {
  const std::string bad = "is invalid: ";
  if (c.next_landmark_id < 0) Fail(bad + "next landmark id " + Str(c.next_landmark_id) + " < 0");
  const auto live = [&](KeyframeId id) { return c.keyframes.count(id) > 0; };
  const auto known = [&](KeyframeId id) {
    return id == kNoId || live(id) || c.culled.count(id) > 0;
  };
  const auto octave_ok = [](int o) { return o >= 0 && o < kMaxOctave; };

  for (const auto& [id, kf] : c.keyframes) {
    const std::string name = "keyframe " + Str(id);
    if (!kf || kf->id != id || id < 0) Fail(bad + name + " has a bad id");
    if (!std::isfinite(kf->stamp_s) || !kf->T_w_c.IsFinite())
      Fail(bad + name + " has a non-finite stamp or pose");
    if (kf->parent != kNoId && (kf->parent == id || !live(kf->parent)))
      Fail(bad + name + " has parent " + Str(kf->parent) + ", which is not a keyframe");
    for (KeyframeId loop : kf->loop_edges)
      if (loop == id || !live(loop))
        Fail(bad + name + " has a loop edge to " + Str(loop) + ", which is not a keyframe");
    const StereoFeatures& f = kf->features;
    if (!GoodDescriptors(f.point_descriptors, f.points.size()) ||
        !GoodDescriptors(f.line_descriptors, f.lines.size()))
      Fail(bad + name + " does not have one 32-byte descriptor per feature");
    if (kf->point_landmarks.size() != f.points.size() ||
        kf->line_landmarks.size() != f.lines.size())
      Fail(bad + name + " does not have one landmark id per feature");
    for (size_t i = 0; i < f.points.size(); ++i) {
      const PointFeature& p = f.points[i];
      if (!Finite(p.uv) || !Finite(p.p_c) || !std::isfinite(p.disparity) || !octave_ok(p.octave))
        Fail(bad + name + " point feature " + Str(i) + " has a non-finite value or bad octave");
      const LandmarkId lm = kf->point_landmarks[i];
      if (lm == kNoId) continue;
      const auto it = c.points.find(lm);
      if (it == c.points.end())
        Fail(bad + name + " point feature " + Str(i) + " refers to missing point landmark " +
             Str(lm));
      const auto obs = it->second->observations.find(id);
      if (obs == it->second->observations.end() || obs->second != static_cast<int>(i))
        Fail(bad + name + " point feature " + Str(i) + " refers to point landmark " + Str(lm) +
             ", which has no such observation");
    }
    for (size_t i = 0; i < f.lines.size(); ++i) {
      const LineFeature& l = f.lines[i];
      if (!Finite(l.s) || !Finite(l.e) || !Finite(l.l) || !std::isfinite(l.angle) ||
          !std::isfinite(l.length) || !Finite(l.P_c) || !Finite(l.Q_c) || !octave_ok(l.octave))
        Fail(bad + name + " line feature " + Str(i) + " has a non-finite value or bad octave");
      const LandmarkId lm = kf->line_landmarks[i];
      if (lm == kNoId) continue;
      const auto it = c.lines.find(lm);
      if (it == c.lines.end())
        Fail(bad + name + " line feature " + Str(i) + " refers to missing line landmark " +
             Str(lm));
      const auto obs = it->second->observations.find(id);
      if (obs == it->second->observations.end() || obs->second != static_cast<int>(i))
        Fail(bad + name + " line feature " + Str(i) + " refers to line landmark " + Str(lm) +
             ", which has no such observation");
    }
  }

  // Observations must point back from the keyframes (the other direction was checked above).
  const auto check_landmark = [&](const std::string& name, LandmarkId key, LandmarkId id,
                                  const cv::Mat& descriptor, int octave, KeyframeId reference,
                                  int created_at, const std::map<KeyframeId, int>& observations,
                                  bool is_point) {
    if (id != key || id < 0 || id >= c.next_landmark_id)
      Fail(bad + name + " has an id outside [0, next landmark id " + Str(c.next_landmark_id) + ")");
    if (!GoodLandmarkDescriptor(descriptor)) Fail(bad + name + " has no 32-byte descriptor");
    if (!octave_ok(octave)) Fail(bad + name + " has octave " + Str(octave));
    if (!known(reference))
      Fail(bad + name + " has reference keyframe " + Str(reference) + ", which is unknown");
    if (created_at < 0 || created_at > c.keyframes_inserted)
      Fail(bad + name + " has created_at " + Str(created_at) + " outside [0, " +
           Str(c.keyframes_inserted) + "]");
    if (observations.empty()) Fail(bad + name + " has no observations");
    for (const auto& [kf_id, index] : observations) {
      const auto kf = c.keyframes.find(kf_id);
      if (kf == c.keyframes.end())
        Fail(bad + name + " is observed in keyframe " + Str(kf_id) + ", which is not in the map");
      const std::vector<LandmarkId>& ids =
          is_point ? kf->second->point_landmarks : kf->second->line_landmarks;
      if (index < 0 || index >= static_cast<int>(ids.size()) || ids[index] != id)
        Fail(bad + name + " is observed in keyframe " + Str(kf_id) + " at feature " + Str(index) +
             ", which does not refer back to it");
    }
  };
  for (const auto& [key, p] : c.points) {
    if (!p) Fail(bad + "point landmark " + Str(key) + " is missing");
    const std::string name = "point landmark " + Str(key);
    if (!Finite(p->p_w)) Fail(bad + name + " has a non-finite position");
    check_landmark(name, key, p->id, p->descriptor, p->octave, p->reference, p->created_at,
                   p->observations, true);
  }
  for (const auto& [key, l] : c.lines) {
    if (!l) Fail(bad + "line landmark " + Str(key) + " is missing");
    const std::string name = "line landmark " + Str(key);
    if (!Finite(l->P_w) || !Finite(l->Q_w)) Fail(bad + name + " has a non-finite endpoint");
    if (c.points.count(key)) Fail(bad + "landmark id " + Str(key) + " is both a point and a line");
    check_landmark(name, key, l->id, l->descriptor, l->octave, l->reference, l->created_at,
                   l->observations, false);
  }

  for (const auto& [id, rec] : c.culled) {
    const std::string name = "culled keyframe " + Str(id);
    if (id < 0 || live(id)) Fail(bad + name + " has a bad id or is also a keyframe");
    if (rec.first == id || !known(rec.first))
      Fail(bad + name + " has parent " + Str(rec.first) + ", which is unknown");
    if (!rec.second.IsFinite()) Fail(bad + name + " has a non-finite pose");
  }
  if (c.keyframes_inserted < static_cast<int64_t>(c.keyframes.size() + c.culled.size()))
    Fail(bad + "keyframes inserted " + Str(c.keyframes_inserted) + " is below the " +
         Str(c.keyframes.size() + c.culled.size()) + " keyframes and culled keyframes");

  // Parent chains (live keyframes, then culled records) end without a cycle.
  const auto check_chains = [&](const std::vector<KeyframeId>& ids,
                                const std::function<KeyframeId(KeyframeId)>& parent_of,
                                const char* what) {
    std::unordered_map<KeyframeId, int> state;  // 1: on the current path, 2: done
    std::vector<KeyframeId> path;
    for (KeyframeId start : ids) {
      path.clear();
      KeyframeId cur = start;
      while (cur != kNoId && state[cur] == 0) {
        state[cur] = 1;
        path.push_back(cur);
        cur = parent_of(cur);
      }
      if (cur != kNoId && state[cur] == 1)
        Fail(bad + std::string(what) + " parents form a cycle through keyframe " + Str(cur));
      for (KeyframeId k : path) state[k] = 2;
    }
  };
  std::vector<KeyframeId> ids;
  for (const auto& kv : c.keyframes) ids.push_back(kv.first);
  check_chains(
      ids, [&](KeyframeId k) { return c.keyframes.at(k)->parent; }, "keyframe");
  ids.clear();
  for (const auto& kv : c.culled) ids.push_back(kv.first);
  check_chains(
      ids,
      [&](KeyframeId k) {
        const auto it = c.culled.find(k);
        return it == c.culled.end() ? kNoId : it->second.first;  // a live keyframe ends it
      },
      "culled keyframe");
}

}  // namespace map_io_internal
}  // namespace pl_slam
