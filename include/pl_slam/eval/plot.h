// Trajectory plot (PNG, drawn with OpenCV): top view of ground truth vs the aligned estimate
// in the plane of largest extent, plus an optional panel of the translation error over time.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "pl_slam/eval/metrics.h"
#include "pl_slam/io/trajectory.h"

namespace pl_slam {
namespace eval {

/// Colours of the plot (BGR), public so tests and callers can find the curves.
inline const cv::Scalar kGroundTruthColor(110, 92, 80);  // slate grey, dashed
inline const cv::Scalar kEstimateColor(180, 119, 31);    // blue

/// Options of RenderTrajectoryPlot.
struct PlotOptions {
  int width = 900;               ///< image width, pixels; >= 400
  int height = 700;              ///< height of the trajectory panel, pixels; >= 300
  int error_panel_height = 230;  ///< height of the error-over-time panel; 0 = no panel, else >= 150
  std::string name;              ///< sequence name for the title (may be empty)

  /// Throws ConfigError naming the bad key and its allowed range.
  void Validate() const;
};

/// Renders the plot: `gt` is the ground truth to draw (any rate, e.g. the full 200 Hz file),
/// `est_aligned` the estimate already in the ground-truth frame, `ate` gives the title value
/// and the per-pose errors of the lower panel. The image is width x (height +
/// error_panel_height), CV_8UC3. Throws InputError when both trajectories are empty.
cv::Mat RenderTrajectoryPlot(const Trajectory& gt, const Trajectory& est_aligned,
                             const AteResult& ate, const PlotOptions& options = {});

/// Renders and writes a PNG; throws InputError naming the path when it cannot be written.
void WriteTrajectoryPlot(const std::string& path, const Trajectory& gt,
                         const Trajectory& est_aligned, const AteResult& ate,
                         const PlotOptions& options = {});

}  // namespace eval
}  // namespace pl_slam
