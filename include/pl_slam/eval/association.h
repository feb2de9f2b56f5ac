// Time association of an estimated trajectory with ground truth.
//
// Ground truth is usually denser than the estimate (EuRoC: 200 Hz ground truth, 20 Hz
// images). Each estimate pose is paired with the ground-truth pose at the same instant,
// interpolated between the two bracketing samples when both lie within max_dt, else the
// nearest sample within max_dt; estimates without such a sample are left out.
#pragma once

#include <cstddef>
#include <vector>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {

/// Options of AssociateTrajectories.
struct AssociationOptions {
  double max_dt = 0.02;     ///< largest |t_est - t_gt| accepted, seconds; > 0
  bool interpolate = true;  ///< interpolate between bracketing samples (else nearest only)

  /// Throws ConfigError naming the bad key and its allowed range.
  void Validate() const;
};

/// Estimate poses and the ground-truth poses paired with them, in time order.
struct Association {
  Trajectory est;  ///< associated estimate poses (time order)
  Trajectory gt;   ///< gt[i] is the ground truth at est[i].t (interpolated or nearest)
  std::vector<std::size_t> est_indices;  ///< index of est[i] in the (time-sorted) input
  std::size_t interpolated = 0;          ///< pairs whose gt pose was interpolated
  std::size_t unmatched = 0;             ///< estimate poses with no gt within max_dt

  std::size_t size() const { return est.size(); }
  bool empty() const { return est.empty(); }
};

/// Interpolates between two poses: linear in translation, slerp in rotation; alpha in [0, 1]
/// (0 -> a, 1 -> b).
SE3 InterpolatePose(const SE3& a, const SE3& b, double alpha);

/// Returns the trajectory sorted by time (stable, so equal stamps keep their order).
Trajectory SortedByTime(const Trajectory& traj);

/// Pairs every estimate pose with the ground truth at its time stamp (see file comment).
/// Inputs need not be sorted. Empty inputs give an empty association (no throw); callers
/// that need poses check Association::empty().
Association AssociateTrajectories(const Trajectory& est, const Trajectory& gt,
                                  const AssociationOptions& options = {});

}  // namespace eval
}  // namespace pl_slam
