// The run-time features of single stereo frames, for vocabulary training, tests and the
// benchmark: the tracker's own front end (detection, LBD, stereo matching and triangulation)
// run on one frame at a time, so the descriptors are exactly those the loop detector sees.
#pragma once

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/io/stereo_frame.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/tracking/stereo_tracker.h"

namespace pl_slam {

/// Extracts StereoFeatures of independent frames with a StereoTracker (reset before each
/// frame, so no frame-to-frame state carries over). Not thread-safe; one per thread.
class LoopFeatureExtractor {
 public:
  /// Throws ConfigError on an invalid camera or options.
  explicit LoopFeatureExtractor(const StereoCamera& camera,
                                const TrackerOptions& options = TrackerOptions());
  ~LoopFeatureExtractor();

  /// Features of one rectified frame (CV_8UC1, camera size). A frame without any stereo
  /// feature gives empty features (the tracker keeps no reference frame then).
  StereoFeatures Extract(const StereoFrame& frame);

 private:
  std::unique_ptr<StereoTracker> tracker_;
};

/// Point and line descriptors of frames of a source, for vocabulary training: frames 0,
/// stride, 2 stride, ... (at most max_frames; 0 = no limit), one matrix per frame appended to
/// *point_descriptors and *line_descriptors. Returns the number of frames used.
int CollectTrainingDescriptors(StereoSource* source, int stride, int max_frames,
                               const TrackerOptions& options,
                               std::vector<cv::Mat>* point_descriptors,
                               std::vector<cv::Mat>* line_descriptors);

}  // namespace pl_slam
