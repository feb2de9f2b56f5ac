#include "pl_slam/util/worker_thread.h"

#include <atomic>
#include <chrono>
#include <set>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>

namespace pl_slam {
namespace {

TEST(WorkerThread, RunsEveryJobOnOneLongLivedThread) {
  WorkerThread worker;
  std::set<std::thread::id> threads;
  int sum = 0;
  for (int i = 1; i <= 50; ++i) {
    std::thread::id id;
    worker.Start([&, i] {
      id = std::this_thread::get_id();
      sum += i;
    });
    worker.Wait();
    threads.insert(id);
  }
  EXPECT_EQ(sum, 50 * 51 / 2);
  ASSERT_EQ(threads.size(), 1u);  // std::async would have made 50 threads
  EXPECT_NE(*threads.begin(), std::this_thread::get_id());
}

TEST(WorkerThread, RunsBesideTheCaller) {
  WorkerThread worker;
  std::atomic<bool> caller_done{false}, seen_by_job{false};
  worker.Start([&] {
    while (!caller_done.load()) std::this_thread::yield();
    seen_by_job = true;
  });
  caller_done = true;  // the job can only finish after this line: it runs concurrently
  worker.Wait();
  EXPECT_TRUE(seen_by_job.load());
}

TEST(WorkerThread, WaitRethrowsTheJobsExceptionOnceAndTheWorkerStaysUsable) {
  WorkerThread worker;
  worker.Start([] { throw std::runtime_error("right image: bad"); });
  EXPECT_THROW(
      {
        try {
          worker.Wait();
        } catch (const std::runtime_error& e) {
          EXPECT_STREQ(e.what(), "right image: bad");
          throw;
        }
      },
      std::runtime_error);
  EXPECT_NO_THROW(worker.Wait());  // reported once
  bool ran = false;
  worker.Start([&] { ran = true; });
  worker.Wait();
  EXPECT_TRUE(ran);
}

TEST(WorkerThread, WaitWithoutAJobReturnsAndDestructionWaitsForARunningJob) {
  std::atomic<bool> finished{false};
  {
    WorkerThread idle;
    idle.Wait();
    WorkerThread worker;
    worker.Start([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
      finished = true;
    });
  }  // the destructor waits for the job before joining
  EXPECT_TRUE(finished.load());
}

}  // namespace
}  // namespace pl_slam
