// Stereo cameras for tests: a pinhole pair with its principal point at the image centre.
#pragma once

#include "pl_slam/camera/stereo_camera.h"

namespace pl_slam {
namespace testing_util {

/// fx = fy = focal, principal point at the centre of a width x height image, baseline in m.
inline StereoCamera CenteredCamera(double focal, double baseline, int width, int height) {
  StereoCamera c;
  c.fx = c.fy = focal;
  c.cx = (width - 1) / 2.0;
  c.cy = (height - 1) / 2.0;
  c.baseline = baseline;
  c.width = width;
  c.height = height;
  return c;
}

/// The EuRoC-sized camera of the synthetic sequences: 752 x 480, f = 450 px, b = 0.11 m.
inline StereoCamera EurocSizedCamera() { return CenteredCamera(450.0, 0.11, 752, 480); }

}  // namespace testing_util
}  // namespace pl_slam
