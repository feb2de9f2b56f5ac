#include "pl_slam/camera/stereo_camera.h"

#include <cmath>
#include <sstream>

namespace pl_slam {

std::string StereoCamera::Validate() const {
  std::ostringstream os;
  auto bad = [](double v) { return !std::isfinite(v); };
  if (bad(fx) || fx <= 0.0)
    os << "fx=" << fx << " must be a positive number";
  else if (bad(fy) || fy <= 0.0)
    os << "fy=" << fy << " must be a positive number";
  else if (width <= 0 || height <= 0)
    os << "image size " << width << "x" << height << " must be positive";
  else if (bad(cx) || cx < 0.0 || cx > width)
    os << "cx=" << cx << " must lie in [0, " << width << "]";
  else if (bad(cy) || cy < 0.0 || cy > height)
    os << "cy=" << cy << " must lie in [0, " << height << "]";
  else if (bad(baseline) || baseline <= 0.0 || baseline > 10.0)
    os << "baseline=" << baseline << " m must lie in (0, 10]";
  else if (bad(doffs) || std::abs(doffs) > 0.5 * width)
    os << "doffs=" << doffs << " px must lie in [-width/2, width/2]";
  return os.str();
}

}  // namespace pl_slam
