// ThreadSanitizer builds only (-DPL_SLAM_SANITIZE=thread): OpenCV runs its cv::parallel_for_
// bodies sequentially in the calling thread. Its TBB pool synchronises inside uninstrumented
// libraries (libtbb, libopencv_core), which TSan cannot see, so every parallel_for_ reads as a
// race on the loop body; run sequentially, TSan checks pl_slam's own threads (tracking's
// left/right detection, local mapping, loop closing) without false reports. The environment
// variable OPENCV_FOR_THREADS_NUM does not stop the TBB pool in OpenCV 4.6; setNumThreads(0)
// does.
#ifdef PL_SLAM_TSAN_BUILD
#include <opencv2/core/utility.hpp>

namespace {
const bool kOpenCvSequential = [] {
  cv::setNumThreads(0);
  return true;
}();
}  // namespace
#endif
