// Background threads (local mapping, its global BA, loop closing) run at a lower scheduling
// priority than tracking, so on a 2-core machine a bundle adjustment takes the CPU time
// tracking leaves over instead of stretching the tracking of the frame that arrives meanwhile.
#pragma once

#include <string>

namespace pl_slam {

/// Raises the calling thread's nice value by `increment` (0-19; the result is capped at 19).
/// On Linux the nice value belongs to the thread, and threads it creates afterwards inherit
/// it. Returns "" on success, else a one-line reason (the thread keeps its priority). Raising
/// a nice value needs no privilege.
std::string LowerThreadPriority(int increment);

/// The calling thread's nice value (0 when it cannot be read).
int ThreadNiceValue();

}  // namespace pl_slam
