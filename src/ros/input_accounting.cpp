#include "pl_slam/ros/input_accounting.h"

#include <iterator>

namespace pl_slam {
namespace ros_layer {

void InputAccounting::Received(Camera c, const void* id, int64_t stamp_ns) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_.received[c];
  if (policy_ == Policy::kExact) {
    // ExactTime keeps one image per stamp and topic: the new one takes the old one's place.
    for (auto it = waiting_[c].begin(); it != waiting_[c].end(); ++it) {
      if (it->stamp_ns == stamp_ns) {
        waiting_[c].erase(it);
        ++counts_.unpaired[c];
        break;
      }
    }
  }
  waiting_[c].push_back({id, stamp_ns});
}

void InputAccounting::AfterSync(Camera c) {
  if (policy_ != Policy::kApproximate) return;
  std::lock_guard<std::mutex> lock(mutex_);
  // ApproximateTime holds at most queue_size images per topic, its oldest go first; what it
  // holds is always the newest part of waiting_[c], so the oldest beyond queue_size are gone.
  while (waiting_[c].size() > queue_size_) {
    waiting_[c].pop_front();
    ++counts_.unpaired[c];
  }
}

bool InputAccounting::TakeLocked(Camera c, const void* id) {
  // From the newest: an address may repeat among older entries ApproximateTime has already
  // freed, never among the images it still holds (the newest ones).
  for (auto it = waiting_[c].rbegin(); it != waiting_[c].rend(); ++it) {
    if (it->id != id) continue;
    auto forward = std::next(it).base();
    if (policy_ == Policy::kApproximate) {
      // Everything that arrived before the paired image has been discarded.
      counts_.unpaired[c] += static_cast<uint32_t>(forward - waiting_[c].begin());
      waiting_[c].erase(waiting_[c].begin(), forward + 1);
    } else {
      waiting_[c].erase(forward);
    }
    return true;
  }
  return false;
}

void InputAccounting::Paired(const void* left, const void* right) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [c, id] : {std::make_pair(kLeft, left), std::make_pair(kRight, right)}) {
    // Not waiting: counted as discarded earlier, but the synchroniser still held it.
    if (!TakeLocked(c, id) && counts_.unpaired[c] > 0) --counts_.unpaired[c];
  }
  ++counts_.in_progress;
}

void InputAccounting::Unpaired(Camera c, const void* id) {
  if (id == nullptr) return;
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = waiting_[c].begin(); it != waiting_[c].end(); ++it) {
    if (it->id == id) {
      waiting_[c].erase(it);
      ++counts_.unpaired[c];
      return;
    }
  }
}

void InputAccounting::FinishPairLocked(uint32_t* counter) {
  ++*counter;
  if (counts_.in_progress > 0) --counts_.in_progress;
}

void InputAccounting::Processed() {
  std::lock_guard<std::mutex> lock(mutex_);
  FinishPairLocked(&counts_.processed);
}

void InputAccounting::Dropped() {
  std::lock_guard<std::mutex> lock(mutex_);
  FinishPairLocked(&counts_.dropped);
}

void InputAccounting::Rejected() {
  std::lock_guard<std::mutex> lock(mutex_);
  FinishPairLocked(&counts_.rejected);
}

void InputAccounting::Restart() {
  std::lock_guard<std::mutex> lock(mutex_);
  const uint32_t pairs_done = counts_.processed + counts_.dropped + counts_.rejected;
  for (int c = 0; c < 2; ++c) {
    counts_.received[c] -= pairs_done + counts_.unpaired[c];
    counts_.unpaired[c] = 0;
  }
  counts_.processed = counts_.dropped = counts_.rejected = 0;
}

InputCounts InputAccounting::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  InputCounts c = counts_;
  c.waiting[kLeft] = static_cast<uint32_t>(waiting_[kLeft].size());
  c.waiting[kRight] = static_cast<uint32_t>(waiting_[kRight].size());
  return c;
}

}  // namespace ros_layer
}  // namespace pl_slam
