#include "pl_slam/ros/stamp_policy.h"

#include <cmath>

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

bool AttachExactStamps(const std::vector<int64_t>& stamps_ns, Trajectory* traj) {
  // The core keeps stamps as seconds in a double (~240 ns steps at 1.4e9 s); the nodelet kept
  // the images' integer stamps, one per pose in the same order. Each must be the pose's
  // stamp to well within that rounding, else they do not belong together and none is used.
  bool match = stamps_ns.size() == traj->size();
  for (std::size_t i = 0; match && i < traj->size(); ++i)
    match = std::abs(static_cast<double>(stamps_ns[i]) * 1e-9 - (*traj)[i].t) < 1e-5;
  if (!match) return false;
  for (std::size_t i = 0; i < traj->size(); ++i) (*traj)[i].t_ns = stamps_ns[i];
  return true;
}

}  // namespace ros_layer
}  // namespace pl_slam
