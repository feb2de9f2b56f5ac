// Image file reading shared by the dataset sources.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>

namespace pl_slam {

/// Reads an image file as 8-bit single channel (colour is converted to gray, 16-bit scaled
/// down). When width > 0 the image must be width x height. Throws InputError naming the file
/// when it is missing, cannot be decoded or has the wrong size.
cv::Mat ReadGrayImage(const std::string& path, int width = 0, int height = 0);

/// Optional per-side step run right after decoding (side 0 = left, 1 = right), e.g.
/// rectification; it writes its result to *out.
using ImagePostProcess = std::function<void(int side, const cv::Mat& raw, cv::Mat* out)>;

/// Reads a stereo pair, decoding (and post-processing) both images concurrently. Without a
/// post step the decoded images are returned as they are. Throws InputError like
/// ReadGrayImage (the left image's error first).
void ReadImagePair(const std::string& left_path, const std::string& right_path, int width,
                   int height, const ImagePostProcess& post, cv::Mat* left, cv::Mat* right);

}  // namespace pl_slam
