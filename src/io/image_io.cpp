#include "pl_slam/io/image_io.h"

#include <algorithm>
#include <exception>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

}  // namespace

cv::Mat ReadGrayImage(const std::string& path, int width, int height) {
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw InputError(path + ": cannot decode image (" + OneLine(e.msg) + ")");
  }
  if (image.empty()) throw InputError(path + ": cannot read image (missing or not an image)");
  if (width > 0 && (image.cols != width || image.rows != height)) {
    std::ostringstream os;
    os << path << ": image is " << image.cols << "x" << image.rows << ", expected " << width << "x"
       << height << " (the calibrated resolution)";
    throw InputError(os.str());
  }
  return image;
}

void ReadImagePair(const std::string& left_path, const std::string& right_path, int width,
                   int height, const ImagePostProcess& post, cv::Mat* left, cv::Mat* right) {
  const std::string* paths[2] = {&left_path, &right_path};
  cv::Mat results[2];
  std::exception_ptr errors[2];
  // PNG decoding dominates the per-frame cost; the two sides are independent.
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int side = range.start; side < range.end; ++side) {
      try {
        cv::Mat raw = ReadGrayImage(*paths[side], width, height);
        if (post) {
          post(side, raw, &results[side]);
        } else {
          results[side] = raw;
        }
      } catch (const cv::Exception& e) {
        errors[side] = std::make_exception_ptr(
            InputError(*paths[side] + ": cannot process image (" + OneLine(e.msg) + ")"));
      } catch (...) {
        errors[side] = std::current_exception();
      }
    }
  });
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  *left = results[0];
  *right = results[1];
}

}  // namespace pl_slam
