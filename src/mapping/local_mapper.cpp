#include "pl_slam/mapping/local_mapper.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "mapping_steps.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"
#include "pl_slam/util/thread_priority.h"
#include "pl_slam/util/validation.h"
#include "pl_slam/util/worker_thread.h"

namespace pl_slam {

std::string MappingOptions::Validate() const {
  std::string e = CheckRange("queue_size", queue_size, 1, 1000);
  if (e.empty()) e = CheckRange("thread_niceness", thread_niceness, 0, 19);
  if (e.empty()) e = CheckRange("window", window, 2, 100);
  if (e.empty()) e = CheckRange("max_fixed_keyframes", max_fixed_keyframes, 0, 1000);
  if (e.empty()) e = CheckRange("refine_min_inliers", refine_min_inliers, 6, 10000);
  if (e.empty()) e = CheckRange("search_radius", search_radius, 0.0, 200.0, true);
  if (e.empty()) e = CheckRange("refine_max_correction", refine_max_correction, 0.0, 100.0, true);
  if (e.empty())
    e = CheckRange("line_triangulation_min_angle_deg", line_triangulation_min_angle_deg, 0.0, 45.0);
  if (e.empty())
    e = CheckRange("line_triangulation_max_depth_baselines", line_triangulation_max_depth_baselines,
                   0.0, 1e4, true);
  if (e.empty()) e = CheckRange("local_map_keyframes", local_map_keyframes, 0, 1000);
  if (e.empty()) e = CheckRange("cull_after_keyframes", cull_after_keyframes, 1, 1000);
  if (e.empty()) e = CheckRange("min_observations", min_observations, 1, 100);
  if (e.empty()) e = CheckRange("redundant_ratio", redundant_ratio, 0.0, 1.0, true);
  if (e.empty()) e = CheckRange("redundant_min_observers", redundant_min_observers, 1, 100);
  if (e.empty()) e = CheckRange("cull_keep_newest", cull_keep_newest, 0, 100000);
  if (e.empty()) e = CheckRange("line_weight", line_weight, 0.0, 100.0, true);
  if (e.empty()) e = CheckRange("stereo_max_depth_baselines", stereo_max_depth_baselines, 0.0, 1e6);
  if (e.empty()) e = CheckRange("track_min_inliers", track_min_inliers, 6, 10000);
  if (e.empty()) e = CheckRange("track_min_inlier_ratio", track_min_inlier_ratio, 0.0, 100.0);
  if (e.empty()) e = CheckRange("track_max_correction", track_max_correction, 0.0, 100.0, true);
  if (e.empty())
    e = CheckRange("track_max_correction_deg", track_max_correction_deg, 0.0, 180.0, true);
  if (e.empty()) e = CheckRange("skip_covered_keyframes", skip_covered_keyframes, 0.0, 10.0);
  if (!e.empty()) return e;
  e = ba.Validate();
  if (!e.empty()) return "ba." + e;
  e = map.Validate();
  if (!e.empty()) return "map." + e;
  return "";
}

struct LocalMapper::Impl {
  mapping::Context ctx;
  mapping::LineTracks line_tracks;
  mapping::PreviousImage previous_image;
  mutable std::mutex mutex;  // guards queue, busy, stop and stats (never held with the map's)
  std::condition_variable work_cv, idle_cv;
  std::deque<KeyframeInput> queue;
  bool busy = false;
  bool stop = false;
  MappingStats stats;
  std::thread thread;
  std::atomic<LoopCloser*> loop{nullptr};
  PoseGraphOptions pose_graph;
  double loop_edge_weight = 1.0;
  bool global_ba = false;
  int global_ba_iterations = 10;
  int global_ba_followup = 0;
  /// Keyframes until the follow-up global BA of the last correction; -1 when none is due.
  int followup_countdown = -1;
  std::atomic<int> corrections{0};
  SE3 last_correction;  // of the newest keyframe at the last loop correction (under `mutex`)
  // Global bundle adjustment. The job and `global_ba_running` belong to the mapping thread;
  // the helper thread only solves the job. `global_ba_pending` (under `mutex`) tells Flush()
  // and Clear() that a result is still to be merged or discarded.
  std::unique_ptr<mapping::GlobalBa> global_ba_job;
  bool global_ba_running = false;
  bool global_ba_pending = false;
  std::atomic<bool> global_ba_abort{false};
  std::atomic<bool> global_ba_done{false};

  /// Corrects the loops the loop closer has verified (mapping thread, between keyframes).
  void CorrectPendingLoops() {
    LoopCloser* const closer = loop.load();
    if (!closer) return;
    LoopDetection detection;
    while (closer->TakeDetection(&detection)) {
      const auto t0 = std::chrono::steady_clock::now();
      SE3 newest;
      if (mapping::CorrectLoop(ctx, detection, pose_graph, loop_edge_weight, &newest)) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          last_correction = newest;
        }
        closer->OnCorrected(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        ++corrections;
        if (global_ba) {
          StartGlobalBa();
          followup_countdown = global_ba_followup > 0 ? global_ba_followup : -1;
        }
      }
    }
  }

  /// Waits for the helper's solve to end (mapping thread); its exception becomes a failure.
  void JoinGlobalBa() {
    try {
      global_ba_thread.Wait();
    } catch (const std::exception& e) {
      global_ba_job->summary.success = false;
      global_ba_job->summary.message = e.what();
    }
    global_ba_running = false;
  }

  /// Merges or discards a finished job (mapping thread) and counts it.
  void FinishGlobalBa(bool discard) {
    const bool merged = !discard && mapping::ApplyGlobalBundleAdjustment(ctx, *global_ba_job);
    if (!merged && !discard)
      PL_LOG_WARN("global bundle adjustment failed: " << global_ba_job->summary.message);
    const double ms = global_ba_job->summary.solve_ms;
    global_ba_job.reset();
    std::lock_guard<std::mutex> lock(mutex);
    if (merged) {
      ++stats.global_bas;
      stats.global_ba_ms.push_back(ms);
    } else {
      ++stats.global_bas_discarded;
    }
    global_ba_pending = false;
  }

  /// Starts a global BA of the map just corrected; a running one is stale: aborted first. False
  /// when the map has fewer than two keyframes.
  bool StartGlobalBa() {
    if (global_ba_running) {
      global_ba_abort = true;
      JoinGlobalBa();
      FinishGlobalBa(true);
    }
    auto job = std::make_unique<mapping::GlobalBa>();
    if (!mapping::PrepareGlobalBundleAdjustment(ctx, job.get())) return false;
    global_ba_job = std::move(job);
    {
      std::lock_guard<std::mutex> lock(mutex);
      global_ba_pending = true;
    }
    global_ba_abort = false;
    if (!ctx.options.threaded) {
      mapping::SolveGlobalBundleAdjustment(ctx, global_ba_iterations, nullptr, global_ba_job.get());
      FinishGlobalBa(false);
      return true;
    }
    global_ba_done = false;
    global_ba_running = true;
    mapping::GlobalBa* const target = global_ba_job.get();
    global_ba_thread.Start([this, target] {
      mapping::SolveGlobalBundleAdjustment(ctx, global_ba_iterations, &global_ba_abort, target);
      global_ba_done = true;
    });
    return true;
  }

  /// Counts the keyframes since the last correction's global BA and starts the follow-up one
  /// when they reach loop.global_ba_followup (later while the first one is still solving).
  void RunFollowUpGlobalBa() {
    if (followup_countdown < 0) return;
    if (followup_countdown > 0) --followup_countdown;
    if (followup_countdown > 0 || global_ba_running) return;
    followup_countdown = -1;
    if (!StartGlobalBa()) return;
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.global_ba_followups;
  }

  /// Merges a global BA whose solve has ended (mapping thread); an aborted one is discarded.
  void PollGlobalBa() {
    if (!global_ba_running) return;
    const bool abort = global_ba_abort.load();
    if (!global_ba_done.load() && !abort) return;
    JoinGlobalBa();
    FinishGlobalBa(abort);
  }

  void Process(KeyframeInput* input) {
    const auto t0 = std::chrono::steady_clock::now();
    const KeyframeId id = input->id;
    PollGlobalBa();
    mapping::InsertKeyframe(ctx, input);
    const BaSummary ba = mapping::LocalBundleAdjustment(ctx, id);
    const int culled = mapping::Cull(ctx, id);
    if (LoopCloser* const closer = loop.load()) {
      closer->OnKeyframe(id);
      CorrectPendingLoops();
      RunFollowUpGlobalBa();
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.keyframes_processed;
    stats.keyframes_culled += culled;
    stats.last_ba_ms = ba.solve_ms;
    stats.last_keyframe_ms = ms;
    if (ba.solve_ms > 0.0) stats.ba_ms.push_back(ba.solve_ms);
    stats.keyframe_ms.push_back(ms);
  }

  void Run() {
    // Before anything else: the global BA's helper thread, created from this one, inherits it.
    const std::string refused = LowerThreadPriority(ctx.options.thread_niceness);
    if (!refused.empty()) PL_LOG_WARN("local mapping keeps the tracking priority: " << refused);
    std::unique_lock<std::mutex> lock(mutex);
    stats.thread_nice = ThreadNiceValue();
    while (true) {
      // Wakes up now and then to correct loops verified while no keyframe came.
      work_cv.wait_for(lock, std::chrono::milliseconds(50),
                       [this] { return stop || !queue.empty(); });
      if (stop) break;
      if (queue.empty()) {
        busy = true;
        lock.unlock();
        try {
          PollGlobalBa();
          CorrectPendingLoops();
        } catch (const std::exception& e) {
          PL_LOG_ERROR("loop correction failed: " << e.what());
        }
        lock.lock();
        busy = false;
        idle_cv.notify_all();
        continue;
      }
      KeyframeInput input = std::move(queue.front());
      queue.pop_front();
      busy = true;
      lock.unlock();
      try {
        Process(&input);
      } catch (const std::exception& e) {
        PL_LOG_ERROR("local mapping: keyframe " << input.id << " failed: " << e.what());
      }
      lock.lock();
      busy = false;
      idle_cv.notify_all();
    }
    lock.unlock();
    if (global_ba_running) {  // stopping: the result is not wanted
      global_ba_abort = true;
      JoinGlobalBa();
      FinishGlobalBa(true);
    }
    lock.lock();
    busy = false;
    idle_cv.notify_all();
  }

  // Last member: destroyed first, so its job never outlives what it uses.
  WorkerThread global_ba_thread;
};

LocalMapper::LocalMapper(const StereoCamera& camera, const MappingOptions& options,
                         const MappingFrontEnd& front_end, Map* map)
    : impl_(std::make_unique<Impl>()) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("mapping." + err);
  impl_->ctx.camera = camera;
  impl_->ctx.options = options;
  impl_->ctx.front_end = front_end;
  impl_->ctx.map = map;
  impl_->ctx.line_tracks = &impl_->line_tracks;
  impl_->ctx.previous_image = &impl_->previous_image;
  if (options.threaded) impl_->thread = std::thread([this] { impl_->Run(); });
}

LocalMapper::~LocalMapper() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stop = true;
    impl_->queue.clear();
  }
  impl_->global_ba_abort = true;
  impl_->work_cv.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

bool LocalMapper::Submit(KeyframeInput keyframe) {
  Impl& s = *impl_;
  if (!s.ctx.options.threaded) {
    s.Process(&keyframe);
    return true;
  }
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (static_cast<int>(s.queue.size()) >= s.ctx.options.queue_size) {
      ++s.stats.keyframes_dropped;
      return false;
    }
    s.queue.push_back(std::move(keyframe));
  }
  s.work_cv.notify_one();
  return true;
}

void LocalMapper::Flush() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->idle_cv.wait(lock, [this] {
    return impl_->stop || (impl_->queue.empty() && !impl_->busy && !impl_->global_ba_pending);
  });
}

bool LocalMapper::Idle() const {
  if (!impl_->ctx.options.threaded) return true;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->queue.empty() && !impl_->busy;
}

void LocalMapper::Clear() {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  impl_->queue.clear();
  impl_->global_ba_abort = true;  // the mapping thread discards it at its next wake-up
  impl_->idle_cv.wait(
      lock, [this] { return impl_->stop || (!impl_->busy && !impl_->global_ba_pending); });
  // Threaded: the mapping thread is idle and needs the mutex to go on; else this is its thread.
  impl_->followup_countdown = -1;
  impl_->last_correction = SE3();
  impl_->line_tracks.clear();
  impl_->previous_image = mapping::PreviousImage();
}

void LocalMapper::SetLoopCloser(LoopCloser* loop, const LoopClosingOptions& options) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->loop.store(loop);
  impl_->pose_graph = options.pose_graph;
  impl_->loop_edge_weight = options.loop_edge_weight;
  impl_->global_ba = options.global_ba;
  impl_->global_ba_iterations = options.global_ba_iterations;
  impl_->global_ba_followup = options.global_ba_followup;
}

int LocalMapper::loop_corrections() const { return impl_->corrections.load(); }

SE3 LocalMapper::last_loop_correction() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->last_correction;
}

MappingStats LocalMapper::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  MappingStats s = impl_->stats;
  s.queue_length = static_cast<int>(impl_->queue.size());
  return s;
}

}  // namespace pl_slam
