// One long-lived helper thread that runs one job at a time for its owner (the tracker detects
// the right image's features on it while the calling thread does the left image).
//
// Why not std::async: it starts a new thread per call, and libraries with per-thread state
// keep some of it after the thread is gone. OpenCV's thread-local buffers (cv::resize inside
// ORB) grew by ~0.7 KB per frame that way, which a long run sees as a slow leak. A persistent
// thread holds that state once.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace pl_slam {

class WorkerThread {
 public:
  WorkerThread() = default;
  WorkerThread(const WorkerThread&) = delete;
  WorkerThread& operator=(const WorkerThread&) = delete;
  /// Waits for a running job, then stops and joins the thread.
  ~WorkerThread();

  /// Starts `job` on the worker (the thread is created on first use). At most one job at a
  /// time: a job still running is waited for first (its exception, if any, is dropped).
  void Start(std::function<void()> job);
  /// Blocks until the job started last has finished; rethrows the exception it threw.
  /// Returns at once when no job was started.
  void Wait();

 private:
  void Loop();

  std::mutex mutex_;
  std::condition_variable cv_;
  std::thread thread_;
  std::function<void()> job_;
  bool has_job_ = false, quit_ = false;
  std::exception_ptr error_;
};

}  // namespace pl_slam
