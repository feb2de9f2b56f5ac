// Image stamps in the nodelet: what a frame whose stamp is not after the previous frame's
// does.
#pragma once

#include <cstdint>
#include <string>

namespace pl_slam {
namespace ros_layer {

/// backwards_stamp_policy: what a stamp older than the previous frame's does.
enum class BackwardsStampPolicy {
  kResetAfter,  ///< restart when it jumps back by more than the threshold, else skip the frame
  kReset,       ///< restart on every backwards stamp
  kIgnore,      ///< always skip the frame (for clocks that jitter but never restart)
};

/// Parses "reset_after", "reset" or "ignore"; false for anything else.
bool ParseBackwardsStampPolicy(const std::string& name, BackwardsStampPolicy* policy);

/// What happens to a frame, from its stamp and the previous frame's.
enum class StampAction {
  kProcess,        ///< later than the previous frame (or the first frame)
  kSkipRepeated,   ///< the previous frame's stamp again
  kSkipBackwards,  ///< earlier, within the jitter the policy tolerates: skipped
  kRestart,        ///< earlier, a new sequence: restart (a new map, or relocalise in the map)
};

/// The action for a frame stamped `stamp_ns` after one stamped `last_ns` (< 0: no previous
/// frame); `reset_after_ns` is backwards_stamp_reset_after in nanoseconds.
StampAction ClassifyStamp(int64_t last_ns, int64_t stamp_ns, BackwardsStampPolicy policy,
                          int64_t reset_after_ns);

}  // namespace ros_layer
}  // namespace pl_slam
