// The pl_slam_evaluate command line: argument parsing, the small readers it needs (frame
// stamps, EuRoC sensor.yaml extrinsics) and the whole run, so tests can drive it without
// spawning the binary.
#pragma once

#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "pl_slam/eval/evaluation.h"
#include "pl_slam/geometry/se3.h"

namespace pl_slam {
namespace eval {

/// Bad command-line usage (unknown flag, missing or malformed value): exit code 2.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& what) : std::runtime_error(what) {}
};

/// Parsed pl_slam_evaluate arguments.
struct EvaluateCliArgs {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  std::string est_path;        ///< --est
  std::string gt_path;         ///< --gt
  std::string est_format;      ///< --est-format (empty: guessed from the file)
  std::string gt_format;       ///< --gt-format (empty: guessed from the file)
  std::string gt_times_path;   ///< --gt-times, stamps of a KITTI ground-truth file
  std::string est_times_path;  ///< --est-times, stamps of a KITTI estimate file
  std::string t_bs_path;       ///< --t-bs, EuRoC sensor.yaml with T_BS of the camera
  bool has_T_B_C = false;      ///< --T_B_C given
  SE3 T_B_C;                   ///< --T_B_C: camera in body frame
  std::string plot_path;       ///< --plot
  bool error_panel = true;     ///< false with --no-error-panel
  std::string json_path;       ///< --json
  std::string name;            ///< --name (default: the estimate file name)
  std::string frame_times;     ///< --frame-times: empty = ground-truth stamps, "none" = off
  bool help = false;           ///< --help / -h
  EvaluationOptions options;   ///< --align, --max-dt, --rpe-frames, --rpe-lengths
};

/// The usage text.
std::string EvaluateUsage();

/// Parses the arguments (without the program name). Throws UsageError.
EvaluateCliArgs ParseEvaluateArgs(const std::vector<std::string>& args);

/// Reads frame time stamps, one per line, first column (comma or blank separated): seconds,
/// or nanoseconds when the field is an integer of 16 or more digits (EuRoC cam0/data.csv,
/// whose "#timestamp [ns],filename" header is skipped like any '#' line). Throws InputError
/// naming the file and line.
std::vector<double> ReadTimestamps(const std::string& path);

/// Parses 16 numbers (blank or comma separated, row-major) into a rigid transform; the last
/// row must be 0 0 0 1 and the rotation orthonormal within 1e-4. Throws InputError starting
/// with `what`.
SE3 ParseRigidTransform16(const std::string& text, const std::string& what);

/// Reads T_BS (the sensor in the body frame) from an EuRoC sensor.yaml: the 16 numbers of
/// "data: [...]" under "T_BS:". Throws InputError naming the file.
SE3 ReadSensorYamlTBS(const std::string& path);

/// Runs the tool: reads, evaluates, prints the table to `out`, writes the plot and JSON.
/// Returns 0 on success, 1 on bad input (one line "pl_slam_evaluate: error: <file>: <what>"
/// on `err`), 2 on bad usage (message and usage on `err`). Never throws.
int RunEvaluateCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace eval
}  // namespace pl_slam
