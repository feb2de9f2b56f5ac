// InputAccounting against message_filters' real synchronisers: random stereo streams with
// missing, late and repeated images go through ExactTime and ApproximateTime exactly as the
// nodelet feeds them, and every image must be in exactly one place at every step.
#include "pl_slam/ros/input_accounting.h"

#include <algorithm>
#include <random>
#include <vector>

#include <boost/bind/bind.hpp>
#include <gtest/gtest.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <ros/time.h>
#include <sensor_msgs/Image.h>

namespace pl_slam {
namespace ros_layer {
namespace {

using sensor_msgs::Image;
using sensor_msgs::ImageConstPtr;
using Camera = InputAccounting::Camera;

struct Arrival {
  Camera camera;
  int64_t stamp_ns;
};

/// A stream of `n` stamps 50 ms apart: each image missing with probability `p_missing`, some
/// repeated, and each arriving up to `max_lag` places after its turn (under 2: each camera's
/// images in stamp order, only the two cameras' interleaving varies).
std::vector<Arrival> RandomStream(int n, double p_missing, double max_lag, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::pair<double, Arrival>> keyed;
  for (int i = 0; i < n; ++i) {
    for (Camera c : {InputAccounting::kLeft, InputAccounting::kRight}) {
      if (u(*rng) < p_missing) continue;
      const int64_t stamp = (1000 + i) * 50000000LL;
      const int copies = u(*rng) < 0.03 ? 2 : 1;
      for (int k = 0; k < copies; ++k)
        keyed.push_back({2 * i + c + max_lag * u(*rng), Arrival{c, stamp}});
    }
  }
  std::sort(keyed.begin(), keyed.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Arrival> out;
  for (const auto& k : keyed) out.push_back(k.second);
  return out;
}

ImageConstPtr MakeImage(int64_t stamp_ns) {
  auto m = boost::make_shared<Image>();
  m->header.stamp.fromNSec(static_cast<uint64_t>(stamp_ns));
  return m;
}

void ExpectBalanced(const InputCounts& c, const char* where) {
  for (int cam = 0; cam < 2; ++cam) {
    EXPECT_EQ(c.received[cam], c.processed + c.dropped + c.rejected + c.unpaired[cam] +
                                   c.waiting[cam] + c.in_progress)
        << where << ", camera " << cam;
  }
}

template <typename Policy>
struct Harness {
  explicit Harness(InputAccounting::Policy kind, size_t q)
      : accounting(kind, q), sync(Policy(static_cast<uint32_t>(q))) {
    using boost::placeholders::_1;
    using boost::placeholders::_2;
    sync.registerCallback(boost::bind(&Harness::OnPair, this, _1, _2));
  }
  void OnPair(const ImageConstPtr& l, const ImageConstPtr& r) {
    accounting.Paired(l.get(), r.get());
    ++pairs;
    last_paired[0] = l;
    last_paired[1] = r;
    // What the nodelet does next: processed, replaced while busy, or refused.
    switch (pairs % 3) {
      case 0:
        accounting.Processed();
        break;
      case 1:
        accounting.Dropped();
        break;
      default:
        accounting.Rejected();
        break;
    }
  }
  /// ExactTime's drop callback, as the nodelet registers it.
  void OnDrop(const ImageConstPtr& l, const ImageConstPtr& r) {
    accounting.Unpaired(InputAccounting::kLeft, l.get());
    accounting.Unpaired(InputAccounting::kRight, r.get());
  }
  void Feed(Camera c, const ImageConstPtr& m) {
    arrivals[c].push_back(m);
    accounting.Received(c, m.get(), static_cast<int64_t>(m->header.stamp.toNSec()));
    c == InputAccounting::kLeft ? sync.template add<0>(m) : sync.template add<1>(m);
    accounting.AfterSync(c);
  }
  InputAccounting accounting;
  message_filters::Synchronizer<Policy> sync;
  uint32_t pairs = 0;
  ImageConstPtr last_paired[2];
  std::vector<ImageConstPtr> arrivals[2];
};

using ExactPolicy = message_filters::sync_policies::ExactTime<Image, Image>;
using ApproxPolicy = message_filters::sync_policies::ApproximateTime<Image, Image>;

TEST(InputAccounting, ExactTimeEveryImageIsInOnePlace) {
  ros::Time::init();
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    const size_t q = 1 + seed % 6;
    Harness<ExactPolicy> h(InputAccounting::Policy::kExact, q);
    h.sync.registerDropCallback(&Harness<ExactPolicy>::OnDrop, &h);
    for (const Arrival& a : RandomStream(300, 0.1, 6, &rng)) {
      h.Feed(a.camera, MakeImage(a.stamp_ns));
      ExpectBalanced(h.accounting.counts(), "exact, during the stream");
    }
    // A last pair newer than everything: ExactTime discards every older image.
    h.Feed(InputAccounting::kLeft, MakeImage(5000 * 50000000LL));
    h.Feed(InputAccounting::kRight, MakeImage(5000 * 50000000LL));
    const InputCounts c = h.accounting.counts();
    ExpectBalanced(c, "exact, at the end");
    EXPECT_EQ(c.in_progress, 0u);
    EXPECT_EQ(c.processed + c.dropped + c.rejected, h.pairs) << "seed " << seed;
    for (int cam = 0; cam < 2; ++cam) {
      EXPECT_EQ(c.waiting[cam], 0u) << "seed " << seed;
      EXPECT_EQ(c.received[cam], h.arrivals[cam].size());
      EXPECT_EQ(c.unpaired[cam], c.received[cam] - h.pairs) << "seed " << seed;
    }
  }
}

TEST(InputAccounting, ApproximateTimeEveryImageIsInOnePlace) {
  ros::Time::init();
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    const size_t q = 2 + seed % 6;
    Harness<ApproxPolicy> h(InputAccounting::Policy::kApproximate, q);
    h.sync.setMaxIntervalDuration(ros::Duration(0.005));
    for (const Arrival& a : RandomStream(300, 0.1, 1.9, &rng)) {
      h.Feed(a.camera, MakeImage(a.stamp_ns));
      ExpectBalanced(h.accounting.counts(), "approximate, during the stream");
    }
    // The right camera silent: ApproximateTime keeps at most q left images, the oldest go.
    for (int k = 0; k < 3 * static_cast<int>(q); ++k)
      h.Feed(InputAccounting::kLeft, MakeImage((4000 + k) * 50000000LL));
    EXPECT_EQ(h.accounting.counts().waiting[InputAccounting::kLeft], q) << "seed " << seed;
    ExpectBalanced(h.accounting.counts(), "approximate, one camera silent");
    for (int k = 0; k < 3; ++k) {
      h.Feed(InputAccounting::kLeft, MakeImage((5000 + k) * 50000000LL));
      h.Feed(InputAccounting::kRight, MakeImage((5000 + k) * 50000000LL));
    }
    const InputCounts c = h.accounting.counts();
    ExpectBalanced(c, "approximate, at the end");
    ASSERT_GT(h.pairs, 0u);
    EXPECT_EQ(c.processed + c.dropped + c.rejected, h.pairs);
    for (int cam = 0; cam < 2; ++cam) {
      // Still waiting: exactly the images that arrived after the last one paired.
      const auto& arr = h.arrivals[cam];
      const auto last = std::find(arr.rbegin(), arr.rend(), h.last_paired[cam]);
      ASSERT_NE(last, arr.rend());
      const auto after = static_cast<uint32_t>(last - arr.rbegin());
      EXPECT_EQ(c.waiting[cam], std::min<uint32_t>(after, static_cast<uint32_t>(q)))
          << "seed " << seed;
      EXPECT_EQ(c.received[cam], arr.size());
    }
  }
}

TEST(InputAccounting, RestartKeepsWhatIsInFlight) {
  InputAccounting a(InputAccounting::Policy::kExact, 5);
  int dummy[6];
  for (int i = 0; i < 3; ++i) {
    a.Received(InputAccounting::kLeft, &dummy[2 * i], i);
    a.Received(InputAccounting::kRight, &dummy[2 * i + 1], i);
  }
  a.Paired(&dummy[0], &dummy[1]);
  a.Processed();
  a.Paired(&dummy[2], &dummy[3]);                    // in progress at the restart
  a.Received(InputAccounting::kLeft, &dummy[0], 2);  // same stamp: replaces the waiting one
  a.Restart();
  InputCounts c = a.counts();
  EXPECT_EQ(c.processed, 0u);
  EXPECT_EQ(c.unpaired[0], 0u);
  EXPECT_EQ(c.in_progress, 1u);
  EXPECT_EQ(c.received[0], 2u);  // the pair in progress and the new left image
  EXPECT_EQ(c.received[1], 2u);  // the pair in progress and right image 2
  ExpectBalanced(c, "after the restart");
  a.Processed();
  c = a.counts();
  EXPECT_EQ(c.processed, 1u);
  ExpectBalanced(c, "after the pair in progress ended");
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
