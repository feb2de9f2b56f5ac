#include "pl_slam/util/worker_thread.h"

#include <utility>

namespace pl_slam {

WorkerThread::~WorkerThread() {
  if (!thread_.joinable()) return;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return !has_job_; });
    quit_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void WorkerThread::Start(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !has_job_; });
  // Started before the job is posted: if the system refuses a thread, the exception leaves
  // the worker as it was (no job that nothing would ever run or Wait() would wait for).
  if (!thread_.joinable()) thread_ = std::thread([this] { Loop(); });
  job_ = std::move(job);
  error_ = nullptr;
  has_job_ = true;
  lock.unlock();
  cv_.notify_all();
}

void WorkerThread::Wait() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !has_job_; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void WorkerThread::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    cv_.wait(lock, [this] { return quit_ || has_job_; });
    if (has_job_) {
      std::function<void()> job = std::move(job_);
      job_ = nullptr;
      lock.unlock();
      std::exception_ptr error;
      try {
        job();
      } catch (...) {
        error = std::current_exception();
      }
      job = nullptr;  // release what the job captured before the owner is told it is done
      lock.lock();
      error_ = error;
      has_job_ = false;
      cv_.notify_all();
    } else if (quit_) {
      return;
    }
  }
}

}  // namespace pl_slam
