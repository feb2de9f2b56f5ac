#include "pl_slam/system/frame_records.h"

namespace pl_slam {

Trajectory ResolveTrajectory(const FrameRecords& records, const KeyframePoseLookup& keyframe_pose,
                             bool interpolate) {
  const size_t n = records.size();
  // Each frame's pose from its own reference keyframe (one lookup per run of frames).
  std::vector<bool> resolved(n, false);
  std::vector<SE3, Eigen::aligned_allocator<SE3>> by_reference(n);
  KeyframeId cached_id = kNoId;
  SE3 cached_pose;
  bool cached_ok = false;
  for (size_t i = 0; i < n; ++i) {
    const FrameRecord& r = records[i];
    if (r.reference == kNoId) continue;
    if (r.reference != cached_id) {
      cached_id = r.reference;
      cached_ok = keyframe_pose(r.reference, &cached_pose);
    }
    if (!cached_ok) continue;
    resolved[i] = true;
    by_reference[i] = cached_pose * r.T_ref_c;
  }
  Trajectory out;
  out.reserve(n);
  size_t start = 0;  // first record of the current reference's run
  while (start < n) {
    size_t end = start;
    while (end < n && records[end].reference == records[start].reference) ++end;
    const double t0 = records[start].stamp_s;
    const bool blend =
        interpolate && end < n && resolved[end] && resolved[start] && records[end].stamp_s > t0;
    // The next reference's correction since tracking, from its first frame.
    const SE3 next_correction = blend ? by_reference[end] * records[end].T_w_c.inverse() : SE3();
    for (size_t i = start; i < end; ++i) {
      const FrameRecord& r = records[i];
      StampedPose sp;
      sp.t = r.stamp_s;
      sp.t_ns = r.stamp_ns;
      sp.T_w_c = resolved[i] ? by_reference[i] : r.T_w_c;
      if (blend) {
        const double f = (r.stamp_s - t0) / (records[end].stamp_s - t0);
        const SE3 from_next = next_correction * r.T_w_c;
        if (f > 0.0) sp.T_w_c = sp.T_w_c * SE3::Exp(f * (sp.T_w_c.inverse() * from_next).Log());
      }
      out.push_back(sp);
    }
    start = end;
  }
  return out;
}

}  // namespace pl_slam
