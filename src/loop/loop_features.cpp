#include "pl_slam/loop/loop_features.h"

#include "pl_slam/util/error.h"

namespace pl_slam {

LoopFeatureExtractor::LoopFeatureExtractor(const StereoCamera& camera,
                                           const TrackerOptions& options)
    : tracker_(std::make_unique<StereoTracker>(camera, options)) {}

LoopFeatureExtractor::~LoopFeatureExtractor() = default;

StereoFeatures LoopFeatureExtractor::Extract(const StereoFrame& frame) {
  tracker_->Reset();
  tracker_->Track(frame);
  return tracker_->last_features();
}

int CollectTrainingDescriptors(StereoSource* source, int stride, int max_frames,
                               const TrackerOptions& options,
                               std::vector<cv::Mat>* point_descriptors,
                               std::vector<cv::Mat>* line_descriptors) {
  if (stride < 1) throw ConfigError("stride must be at least 1");
  LoopFeatureExtractor extractor(source->camera(), options);
  StereoFrame frame;
  int index = 0, used = 0;
  while ((max_frames <= 0 || used < max_frames) && source->Next(&frame)) {
    if (index++ % stride != 0) continue;
    const StereoFeatures f = extractor.Extract(frame);
    if (point_descriptors && !f.point_descriptors.empty())
      point_descriptors->push_back(f.point_descriptors.clone());
    if (line_descriptors && !f.line_descriptors.empty())
      line_descriptors->push_back(f.line_descriptors.clone());
    ++used;
  }
  return used;
}

}  // namespace pl_slam
