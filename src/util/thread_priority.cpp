#include "pl_slam/util/thread_priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace pl_slam {
namespace {

id_t ThisThreadId() { return static_cast<id_t>(syscall(SYS_gettid)); }

}  // namespace

int ThreadNiceValue() {
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, ThisThreadId());
  return errno == 0 ? nice : 0;
}

std::string LowerThreadPriority(int increment) {
  if (increment < 0 || increment > 19)
    return "thread niceness " + std::to_string(increment) + " is outside [0, 19]";
  if (increment == 0) return "";
  const int target = std::min(19, ThreadNiceValue() + increment);
  if (setpriority(PRIO_PROCESS, ThisThreadId(), target) != 0)
    return std::string("setpriority(") + std::to_string(target) +
           ") failed: " + std::strerror(errno);
  return "";
}

}  // namespace pl_slam
