#include "pl_slam/ros/stamp_policy.h"

namespace pl_slam {
namespace ros_layer {

bool ParseBackwardsStampPolicy(const std::string& name, BackwardsStampPolicy* policy) {
  if (name == "reset_after") {
    *policy = BackwardsStampPolicy::kResetAfter;
  } else if (name == "reset") {
    *policy = BackwardsStampPolicy::kReset;
  } else if (name == "ignore") {
    *policy = BackwardsStampPolicy::kIgnore;
  } else {
    return false;
  }
  return true;
}

StampAction ClassifyStamp(int64_t last_ns, int64_t stamp_ns, BackwardsStampPolicy policy,
                          int64_t reset_after_ns) {
  if (last_ns < 0 || stamp_ns > last_ns) return StampAction::kProcess;
  if (stamp_ns == last_ns) return StampAction::kSkipRepeated;
  switch (policy) {
    case BackwardsStampPolicy::kReset:
      return StampAction::kRestart;
    case BackwardsStampPolicy::kIgnore:
      return StampAction::kSkipBackwards;
    case BackwardsStampPolicy::kResetAfter:
      break;
  }
  return last_ns - stamp_ns > reset_after_ns ? StampAction::kRestart : StampAction::kSkipBackwards;
}

}  // namespace ros_layer
}  // namespace pl_slam
