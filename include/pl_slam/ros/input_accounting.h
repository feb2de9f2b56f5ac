// Where every stereo image the nodelet received is: waiting in the synchroniser for its
// partner, discarded there without one (unpaired), or part of a synchronised pair that is in
// progress, processed, dropped (the worker was busy) or rejected (bad input).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <utility>

namespace pl_slam {
namespace ros_layer {

/// Counts of InputAccounting. For each camera c, at every snapshot:
///   received[c] = processed + dropped + rejected + unpaired[c] + waiting[c] + in_progress
struct InputCounts {
  uint32_t received[2] = {0, 0};  ///< images that reached the subscriber callback
  uint32_t unpaired[2] = {0, 0};  ///< discarded by the synchroniser without a partner
  uint32_t waiting[2] = {0, 0};   ///< held by the synchroniser for a partner
  uint32_t processed = 0;         ///< pairs the pipeline processed
  uint32_t dropped = 0;           ///< pairs replaced by a newer one while the worker was busy
  uint32_t rejected = 0;          ///< pairs refused as bad input or failed in the pipeline
  uint32_t in_progress = 0;       ///< pairs synchronised but not yet in one of the three above
};

/// The bookkeeping of the nodelet's input, mirroring what message_filters' synchroniser does
/// with each image. Every image enters through Received(); it leaves `waiting` when the
/// synchroniser pairs it (Paired) or discards it (Unpaired, or the rules below); every pair
/// leaves `in_progress` through exactly one of Processed, Dropped or Rejected. Thread-safe.
///
/// ExactTime holds one image per stamp and topic, and reports what it discards through its drop
/// callback (Unpaired); an image arriving with the stamp of one still waiting on the same topic
/// replaces it there, so that one is unpaired at once. ApproximateTime reports nothing: it
/// holds at most queue_size images per topic and only ever discards a topic's oldest, so an
/// image older (in arrival order) than a paired one is unpaired, and so are the oldest beyond
/// queue_size (AfterSync).
class InputAccounting {
 public:
  enum Camera { kLeft = 0, kRight = 1 };
  enum class Policy { kExact, kApproximate };

  InputAccounting(Policy policy, size_t queue_size) : policy_(policy), queue_size_(queue_size) {}

  /// An image arrived; `id` identifies the message (its address) until it leaves `waiting`.
  /// Call before giving it to the synchroniser.
  void Received(Camera c, const void* id, int64_t stamp_ns);
  /// Call after the synchroniser has seen the image Received() announced last on `c`.
  void AfterSync(Camera c);
  /// The synchroniser emitted the pair (left, right).
  void Paired(const void* left, const void* right);
  /// ExactTime's drop callback: this image (nullptr: none on this camera) was discarded.
  void Unpaired(Camera c, const void* id);
  /// A pair in progress ended.
  void Processed();
  void Dropped();
  void Rejected();
  /// Counters restart (a reset of the map): processed, dropped, rejected and unpaired become
  /// 0 and received keeps only the images still waiting or in progress, which are counted
  /// after the restart like any other.
  void Restart();
  InputCounts counts() const;

 private:
  struct Waiting {
    const void* id;
    int64_t stamp_ns;
  };
  void FinishPairLocked(uint32_t* counter);
  /// Removes `id` from camera c's waiting images (searched from the newest); false if absent.
  bool TakeLocked(Camera c, const void* id);

  const Policy policy_;
  const size_t queue_size_;
  mutable std::mutex mutex_;
  std::deque<Waiting> waiting_[2];  // in arrival order
  InputCounts counts_;
};

}  // namespace ros_layer
}  // namespace pl_slam
