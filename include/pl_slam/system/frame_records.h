// The per-frame trajectory record of SlamSystem and how it becomes a trajectory.
//
// A frame is kept relative to the keyframe it was tracked after (its reference), so that
// bundle adjustment and loop corrections, which move keyframes, move the frames too.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/StdVector>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/map/map.h"

namespace pl_slam {

/// A tracked frame.
struct FrameRecord {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  double stamp_s = 0.0;
  int64_t stamp_ns =
      -1;     ///< the image's exact stamp (-1 = unknown), carried into StampedPose::t_ns
  SE3 T_w_c;  ///< as tracked
  KeyframeId reference = kNoId;  ///< keyframe it was tracked after (kNoId: none yet)
  SE3 T_ref_c;                   ///< pose relative to the reference keyframe as then estimated
};
using FrameRecords = std::vector<FrameRecord, Eigen::aligned_allocator<FrameRecord>>;

/// The current pose of a keyframe; false when unknown (ignored: the frame keeps its pose).
using KeyframePoseLookup = std::function<bool(KeyframeId, SE3*)>;

/// The trajectory of `records` (in order, one pose each) with the keyframes' current poses.
///  - Without interpolation a frame follows its reference keyframe a:
///    (a now) * T_ref_c, i.e. a's correction since tracking applied to the tracked pose.
///  - With it, a frame between a and the next reference b (the reference of the first later
///    record with another one) blends that pose with b's correction applied to its tracked
///    pose, by its time between their first frames: a's alone at a's first frame, tending to
///    b's at b's. When bundle adjustment or a loop correction moves a and b differently, the
///    trajectory then has no step where the reference changes.
/// Frames without a reference, or whose reference is unknown, keep their tracked pose.
Trajectory ResolveTrajectory(const FrameRecords& records, const KeyframePoseLookup& keyframe_pose,
                             bool interpolate);

}  // namespace pl_slam
