#include "pl_slam/util/thread_priority.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <thread>

namespace pl_slam {
namespace {

TEST(ThreadPriorityTest, LowersOnlyTheCallingThreadAndItsLaterChildren) {
  const int base = ThreadNiceValue();
  int lowered = -100, child = -100;
  std::string refused = "not run";
  std::thread worker([&] {
    refused = LowerThreadPriority(4);
    lowered = ThreadNiceValue();
    std::thread grandchild([&] { child = ThreadNiceValue(); });
    grandchild.join();
  });
  worker.join();
  EXPECT_EQ(refused, "");
  EXPECT_EQ(lowered, std::min(19, base + 4));
  EXPECT_EQ(child, lowered);           // created after the change: inherits it
  EXPECT_EQ(ThreadNiceValue(), base);  // the caller of std::thread is untouched
}

TEST(ThreadPriorityTest, ZeroIsANoOpAndOutOfRangeIsRefusedByValue) {
  std::string zero, negative, large;
  int after_zero = -100, after_refused = -100, base = -100;
  std::thread worker([&] {
    base = ThreadNiceValue();
    zero = LowerThreadPriority(0);
    after_zero = ThreadNiceValue();
    negative = LowerThreadPriority(-1);
    large = LowerThreadPriority(20);
    after_refused = ThreadNiceValue();
  });
  worker.join();
  EXPECT_EQ(zero, "");
  EXPECT_EQ(after_zero, base);
  EXPECT_NE(negative.find("-1"), std::string::npos) << negative;
  EXPECT_NE(large.find("20"), std::string::npos) << large;
  EXPECT_EQ(after_refused, base);
}

TEST(ThreadPriorityTest, TheResultIsCappedAtNineteen) {
  int nice = -100;
  std::string refused = "not run";
  std::thread worker([&] {
    LowerThreadPriority(15);
    refused = LowerThreadPriority(15);
    nice = ThreadNiceValue();
  });
  worker.join();
  EXPECT_EQ(refused, "");
  EXPECT_EQ(nice, 19);
}

}  // namespace
}  // namespace pl_slam
