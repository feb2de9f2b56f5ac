// Internal to the generator (src/sim): what the lowtex walks and the street drives share for
// their timing. A smooth step, and the arc length along a path at each time step of a speed
// profile, integrated once and looked up by time.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace pl_slam::sim {

// Smooth step 0 -> 1 over [0, 1].
inline double Smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

// Arc length at each time step of kDt s for a speed given as a function of the arc length
// (m/s), from 0 up to `length`.
class ArcLengthTable {
 public:
  template <typename Speed>
  ArcLengthTable(double length, Speed speed_at) {
    s_.push_back(0.0);
    double s = 0.0;
    while (s < length) {
      s = std::min(length, s + speed_at(s) * kDt);
      s_.push_back(s);
    }
  }
  double duration() const { return (s_.size() - 1) * kDt; }
  double ArcLength(double t) const {
    const double x = std::clamp(t / kDt, 0.0, static_cast<double>(s_.size() - 1));
    const std::size_t i = std::min(static_cast<std::size_t>(x), s_.size() - 2);
    return s_[i] + (x - i) * (s_[i + 1] - s_[i]);
  }

 private:
  static constexpr double kDt = 0.002;
  std::vector<double> s_;
};

}  // namespace pl_slam::sim
