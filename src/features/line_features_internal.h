// Shared by line detection (line_features.cpp) and the LBD descriptor (line_descriptor.cpp):
// the gradients are computed once per image and used by both. Not part of the public API.
#pragma once

#include <opencv2/core.hpp>

#include "pl_slam/features/line_features.h"

namespace pl_slam {
namespace line_internal {

/// The gradients LBD is defined on (5x5 Gaussian blur, then 3x3 Sobel, CV_16S); the
/// edge-chain detector reuses them so Sobel runs once.
void ComputeGradients(const cv::Mat& image, cv::Mat* blurred, cv::Mat* dx, cv::Mat* dy);

/// LBD of every line, row i for line i (32 bytes each), from ComputeGradients' dx and dy.
void LbdFromGradients(const cv::Mat& dx, const cv::Mat& dy, const LineFeatures& lines,
                      cv::Mat* descriptors);

}  // namespace line_internal
}  // namespace pl_slam
