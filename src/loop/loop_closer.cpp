#include "pl_slam/loop/loop_closer.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <set>
#include <thread>
#include <unordered_set>
#include <utility>

#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"
#include "pl_slam/util/thread_priority.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

std::string LoopClosingOptions::Validate() const {
  std::string e = CheckRange("queue_size", queue_size, 1, 10000);
  if (e.empty()) e = CheckRange("thread_niceness", thread_niceness, 0, 19);
  if (e.empty()) e = CheckRange("min_keyframe_gap", min_keyframe_gap, 1, 100000);
  if (e.empty()) e = CheckRange("max_candidates", max_candidates, 1, 100);
  if (e.empty()) e = CheckRange("min_score", min_score, 0.0, 1.0);
  if (e.empty()) e = CheckRange("min_normalized_score", min_normalized_score, 0.0, 10.0);
  if (e.empty()) e = CheckRange("consistency", consistency, 1, 100);
  if (e.empty()) e = CheckRange("relocalize_candidates", relocalize_candidates, 1, 100);
  if (e.empty()) e = CheckRange("loop_edge_weight", loop_edge_weight, 0.0, 1e6, true);
  if (e.empty()) e = CheckRange("max_drift_ratio", max_drift_ratio, 0.0, 1e6);
  if (e.empty()) e = CheckRange("max_drift_floor", max_drift_floor, 0.0, 1e6);
  if (e.empty()) e = CheckRange("global_ba_iterations", global_ba_iterations, 1, 1000);
  if (e.empty()) e = CheckRange("global_ba_followup", global_ba_followup, 0, 100000);
  if (!e.empty()) return e;
  e = database.Validate();
  if (!e.empty()) return "database." + e;
  e = verification.Validate();
  if (!e.empty()) return "verification." + e;
  e = pose_graph.Validate();
  if (!e.empty()) return "pose_graph." + e;
  return "";
}

LoopOdometryCheck CheckLoopAgainstOdometry(const SE3& T_w_query, const SE3& T_w_candidate,
                                           const SE3& T_query_candidate, double path_length,
                                           const LoopClosingOptions& options) {
  LoopOdometryCheck c;
  c.path_length = path_length;
  const SE3 T_w_query_loop = T_w_candidate * T_query_candidate.inverse();
  c.correction = (T_w_query_loop.translation() - T_w_query.translation()).norm();
  c.allowed = options.max_drift_floor + options.max_drift_ratio * path_length;
  c.plausible = c.correction <= c.allowed;  // false for NaN
  return c;
}

double KeyframePathLengthLocked(const Map& map, KeyframeId from, KeyframeId to) {
  if (from > to) std::swap(from, to);
  const auto& keyframes = map.KeyframesLocked();
  double length = 0.0;
  const Keyframe* previous = nullptr;
  for (auto it = keyframes.lower_bound(from); it != keyframes.end() && it->first <= to; ++it) {
    if (previous)
      length += (it->second->T_w_c.translation() - previous->T_w_c.translation()).norm();
    previous = it->second.get();
  }
  return length;
}

namespace {
using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

struct LoopCloser::Impl {
  StereoCamera camera;
  LoopClosingOptions options;
  Map* map = nullptr;
  PointLineVocabulary vocabulary;
  KeyframeDatabase database;
  // Lock order: `mutex` (queue, detections, stats, groups) is never held while taking
  // the map's lock or the database's; the map's lock is a leaf.
  mutable std::mutex mutex;
  std::condition_variable work_cv, idle_cv;
  std::deque<KeyframeId> queue;
  bool busy = false, stop = false;
  std::deque<LoopDetection> detections;
  LoopStats stats;
  // Candidate groups (candidate + its covisible keyframes) of the previous query, with how
  // many consecutive keyframes they have been seen by.
  std::vector<std::pair<std::set<KeyframeId>, int>> groups;
  std::thread thread;

  Impl(const StereoCamera& cam, const LoopClosingOptions& opt, Map* m)
      : camera(cam), options(opt), map(m), database(opt.database) {}

  KeyframeBow Bow(const StereoFeatures& f) const {
    return ComputeKeyframeBow(f, vocabulary, camera.width, camera.height, options.database);
  }

  void Process(KeyframeId id) {
    const auto t0 = Clock::now();
    std::shared_ptr<const Keyframe> kf;
    std::vector<std::pair<KeyframeId, int>> covisible;
    {
      auto lock = map->Lock();
      kf = map->KeyframeLocked(id);
      if (kf) covisible = map->CovisibleLocked(id, 1);
    }
    if (!kf) return;  // culled meanwhile
    const KeyframeBow bow = Bow(kf->features);
    // Normalisation: the best score among the covisible neighbours that are in the database.
    // Covisible keyframes are excluded in the query; recent ones (within min_keyframe_gap)
    // are dropped from its results, so the query stays an inverted-index lookup.
    double best_neighbour = 0.0;
    std::unordered_set<int> exclude;
    for (const auto& [k, n] : covisible) {
      exclude.insert(static_cast<int>(k));
      double score = 0.0;
      if (database.ScoreAgainst(bow, static_cast<int>(k), &score))
        best_neighbour = std::max(best_neighbour, score);
    }
    std::vector<LoopCandidate> candidates;
    for (const LoopCandidate& c :
         database.Query(bow, options.max_candidates + options.min_keyframe_gap, &exclude)) {
      if (c.id > id - options.min_keyframe_gap) continue;
      candidates.push_back(c);
      if (static_cast<int>(candidates.size()) >= options.max_candidates) break;
    }
    database.Add(static_cast<int>(id), bow);
    // Keyframes culled by local mapping leave the database here, not only when they come up as
    // candidates: otherwise it keeps every keyframe ever inserted (the 10,000-frame soak grew
    // by ~1.4 MB per 1000 frames with a map of constant size). The database and the map are
    // locked one after the other, never together.
    {
      const std::vector<int> indexed = database.ids();
      std::vector<int> gone;
      {
        auto lock = map->Lock();
        for (int k : indexed)
          if (!map->KeyframeLocked(static_cast<KeyframeId>(k))) gone.push_back(k);
      }
      for (int k : gone) database.Remove(k);
    }
    // Candidate groups that pass the scores, with their consistency.
    std::vector<std::pair<std::set<KeyframeId>, int>> current;
    std::vector<KeyframeId> ready;
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.keyframes_queried;
      stats.query_ms.push_back(MsSince(t0));
    }
    for (const LoopCandidate& c : candidates) {
      if (c.score < options.min_score) continue;
      if (best_neighbour > 0.0 && c.score < options.min_normalized_score * best_neighbour) continue;
      std::set<KeyframeId> group{c.id};
      {
        auto lock = map->Lock();
        if (!map->KeyframeLocked(c.id)) {
          lock.unlock();
          database.Remove(c.id);
          continue;
        }
        for (const auto& [k, n] : map->CovisibleLocked(c.id, 1)) group.insert(k);
      }
      int consistency = 1;
      {
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& [g, count] : groups) {
          bool shared = false;
          for (KeyframeId k : group)
            if (g.count(k)) {
              shared = true;
              break;
            }
          if (shared) consistency = std::max(consistency, count + 1);
        }
      }
      current.emplace_back(group, consistency);
      if (consistency >= options.consistency) ready.push_back(c.id);
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      groups = current;
    }
    for (KeyframeId cand_id : ready) {
      std::shared_ptr<const Keyframe> cand;
      {
        auto lock = map->Lock();
        cand = map->KeyframeLocked(cand_id);
      }
      if (!cand) continue;
      const RelativePose rel =
          EstimateRelativePose(camera, kf->features, cand->features, options.verification);
      LoopOdometryCheck odometry;
      if (rel.success) {
        auto lock = map->Lock();
        const auto q = map->KeyframeLocked(id);
        const auto c = map->KeyframeLocked(cand_id);
        if (!q || !c) continue;  // culled meanwhile
        odometry = CheckLoopAgainstOdometry(q->T_w_c, c->T_w_c, rel.T_query_candidate,
                                            KeyframePathLengthLocked(*map, cand_id, id), options);
      }
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.candidates_verified;
      if (!rel.success) {
        PL_LOG_DEBUG("loop candidate " << cand_id << " for keyframe " << id
                                       << " rejected: " << rel.failure);
        continue;
      }
      if (!odometry.plausible) {
        ++stats.rejected_by_odometry;
        PL_LOG_DEBUG("loop candidate " << cand_id << " for keyframe " << id << " rejected: "
                                       << "it moves the keyframe " << odometry.correction
                                       << " m, more than the " << odometry.allowed
                                       << " m of drift plausible over the " << odometry.path_length
                                       << " m path since the candidate");
        continue;
      }
      LoopDetection d;
      d.query = id;
      d.candidate = cand_id;
      d.T_query_candidate = rel.T_query_candidate;
      d.inliers = rel.point_inliers + rel.line_inliers;
      d.query_frame = kf->frame_index;
      d.candidate_frame = cand->frame_index;
      detections.push_back(d);
      stats.loops.push_back(d);
      ++stats.loops_detected;
      groups.clear();  // a closed loop starts a new consistency history
      PL_LOG_INFO("loop detected: keyframe " << id << " sees keyframe " << cand_id << " ("
                                             << d.inliers << " inliers)");
      break;
    }
  }

  void Run() {
    const std::string refused = LowerThreadPriority(options.thread_niceness);
    if (!refused.empty()) PL_LOG_WARN("loop closing keeps the tracking priority: " << refused);
    std::unique_lock<std::mutex> lock(mutex);
    stats.thread_nice = ThreadNiceValue();
    while (true) {
      work_cv.wait(lock, [this] { return stop || !queue.empty(); });
      if (stop) break;
      const KeyframeId id = queue.front();
      queue.pop_front();
      busy = true;
      lock.unlock();
      try {
        Process(id);
      } catch (const std::exception& e) {
        PL_LOG_ERROR("loop closing: keyframe " << id << " failed: " << e.what());
      }
      lock.lock();
      busy = false;
      idle_cv.notify_all();
    }
    busy = false;
    idle_cv.notify_all();
  }
};

LoopCloser::LoopCloser(const StereoCamera& camera, const LoopClosingOptions& options, Map* map,
                       bool threaded) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("loop." + err);
  impl_ = std::make_unique<Impl>(camera, options, map);
  impl_->vocabulary = PointLineVocabulary::LoadFolder(options.vocabulary);
  if (threaded) impl_->thread = std::thread([this] { impl_->Run(); });
}

LoopCloser::~LoopCloser() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stop = true;
    impl_->queue.clear();
  }
  impl_->work_cv.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void LoopCloser::OnKeyframe(KeyframeId id) {
  Impl& s = *impl_;
  if (!s.thread.joinable()) {
    s.Process(id);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (static_cast<int>(s.queue.size()) >= s.options.queue_size) {
      ++s.stats.keyframes_skipped;
      return;
    }
    s.queue.push_back(id);
  }
  s.work_cv.notify_one();
}

bool LoopCloser::TakeDetection(LoopDetection* detection) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->detections.empty()) return false;
  *detection = impl_->detections.front();
  impl_->detections.pop_front();
  return true;
}

bool LoopCloser::HasDetection() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return !impl_->detections.empty();
}

void LoopCloser::OnCorrected(double ms) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  ++impl_->stats.loops_corrected;
  impl_->stats.correction_ms.push_back(ms);
}

bool LoopCloser::Relocalize(const StereoFeatures& frame, SE3* T_w_c, KeyframeId* keyframe) {
  Impl& s = *impl_;
  if (frame.points.empty() && frame.lines.empty()) return false;
  const KeyframeBow bow = s.Bow(frame);
  for (const LoopCandidate& c : s.database.Query(bow, s.options.relocalize_candidates)) {
    std::shared_ptr<const Keyframe> kf;
    SE3 T_w_kf;
    {
      auto lock = s.map->Lock();
      kf = s.map->KeyframeLocked(c.id);
      if (kf) T_w_kf = kf->T_w_c;
    }
    if (!kf) continue;
    const RelativePose rel =
        EstimateRelativePose(s.camera, frame, kf->features, s.options.verification);
    if (!rel.success) continue;
    *T_w_c = T_w_kf * rel.T_query_candidate.inverse();
    *keyframe = c.id;
    std::lock_guard<std::mutex> lock(s.mutex);
    ++s.stats.relocalizations;
    return true;
  }
  return false;
}

void LoopCloser::Flush() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->idle_cv.wait(lock,
                      [this] { return impl_->stop || (impl_->queue.empty() && !impl_->busy); });
}

void LoopCloser::IndexMap() {
  Impl& s = *impl_;
  std::vector<std::shared_ptr<const Keyframe>> keyframes;
  {
    auto lock = s.map->Lock();
    for (const auto& [id, kf] : s.map->KeyframesLocked()) keyframes.push_back(kf);
  }
  for (const auto& kf : keyframes) {
    s.database.Add(static_cast<int>(kf->id), s.Bow(kf->features));
  }
}

void LoopCloser::Clear() {
  {
    std::unique_lock<std::mutex> lock(impl_->mutex);
    impl_->queue.clear();
    impl_->idle_cv.wait(lock, [this] { return impl_->stop || !impl_->busy; });
    impl_->detections.clear();
    impl_->groups.clear();
  }
  impl_->database.Clear();
}

LoopStats LoopCloser::stats() const {
  LoopStats s;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    s = impl_->stats;
  }
  s.database_keyframes = static_cast<int>(impl_->database.size());
  return s;
}

}  // namespace pl_slam
