// Stamped pose sequences and their file formats (TUM, KITTI, EuRoC ground truth).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/StdVector>

#include "pl_slam/geometry/se3.h"

namespace pl_slam {

/// One pose of a trajectory: the camera (or body) pose in the world frame at time t.
struct StampedPose {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  double t = 0.0;  ///< seconds
  SE3 T_w_c;       ///< pose of the tracked frame in the world frame
  /// The exact stamp in nanoseconds when known (the nodelet's image stamps), else -1; TUM and
  /// EuRoC files are written from it then (a double holds a 1.4e9 s stamp only to ~240 ns).
  /// Whoever changes t must reset it.
  int64_t t_ns = -1;
};

using Trajectory = std::vector<StampedPose, Eigen::aligned_allocator<StampedPose>>;

enum class TrajectoryFormat { kTum, kKitti, kEuroc };

/// Parses "tum", "kitti" or "euroc" (case-insensitive); throws InputError naming the value.
TrajectoryFormat ParseTrajectoryFormat(const std::string& name);

/// Reads a TUM file: "t tx ty tz qx qy qz qw" per line, '#' comments. Throws InputError with
/// the file and line number on malformed content.
Trajectory ReadTumTrajectory(const std::string& path);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
Trajectory ParseTumTrajectory(const std::string& content, const std::string& path);

/// Reads a KITTI poses file (12 numbers per line, row-major 3x4). Times are taken from
/// `times` when it is non-empty (same length required), else the line index is used.
Trajectory ReadKittiTrajectory(const std::string& path, const std::vector<double>& times = {});
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
Trajectory ParseKittiTrajectory(const std::string& content, const std::string& path,
                                const std::vector<double>& times);

/// Reads an EuRoC state_groundtruth_estimate0/data.csv (or any EuRoC pose csv whose first 8
/// columns are t[ns], p xyz, q wxyz). Poses are of the body frame; compose with T_B_C to get
/// the camera trajectory.
Trajectory ReadEurocTrajectory(const std::string& path);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
Trajectory ParseEurocTrajectory(const std::string& content, const std::string& path);

/// Reads a trajectory in the given format.
Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format);

/// Guesses the format from the file name and content (".csv" -> EuRoC, 12 columns -> KITTI,
/// else TUM).
TrajectoryFormat GuessTrajectoryFormat(const std::string& path);

/// Formats a trajectory as text in the given format.
std::string FormatTrajectory(const Trajectory& traj, TrajectoryFormat format);

/// Writes the trajectory atomically (temporary file in the same folder, then rename).
/// Throws InputError when the folder is not writable.
void WriteTrajectory(const std::string& path, const Trajectory& traj, TrajectoryFormat format);

/// Writes `content` to `path` atomically: a crash leaves either the old file or the new one.
/// Temporary files a killed writer left next to `path` are removed first.
void WriteFileAtomic(const std::string& path, const std::string& content);

/// Removes the temporary files of WriteFileAtomic(`path`) whose writer process no longer
/// exists (a save interrupted by kill -9); returns how many. Live writers' files stay.
int RemoveStaleTemporaryFiles(const std::string& path);

/// Returns traj with every pose right-multiplied by T (e.g. body poses -> camera poses).
Trajectory TransformTrajectory(const Trajectory& traj, const SE3& T_right);

}  // namespace pl_slam
