#include "pl_slam/camera/stereo_camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pl_slam {

bool StereoCamera::SegmentInView(const Eigen::Vector3d& P_c, const Eigen::Vector3d& Q_c,
                                 double min_depth, double* t0, double* t1) const {
  const Eigen::Vector3d D = Q_c - P_c;
  // Every bound is linear in t once multiplied by the depth: z >= min_depth, u >= 0
  // (fx x + cx z >= 0), u <= width - 1, v >= 0, v <= height - 1.
  const Eigen::Vector3d bounds[] = {
      {0.0, 0.0, 1.0},
      {fx, 0.0, cx},
      {-fx, 0.0, width - 1.0 - cx},
      {0.0, fy, cy},
      {0.0, -fy, height - 1.0 - cy},
  };
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 5; ++k) {
    const double a = bounds[k].dot(P_c) - (k == 0 ? min_depth : 0.0), b = bounds[k].dot(D);
    if (std::abs(b) < 1e-12) {
      if (!(a >= 0.0)) return false;
    } else if (b > 0.0) {
      lo = std::max(lo, -a / b);
    } else {
      hi = std::min(hi, -a / b);
    }
  }
  if (!(hi > lo)) return false;
  *t0 = lo;
  *t1 = hi;
  return true;
}

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
