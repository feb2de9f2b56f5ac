// Helpers for the options structs' Validate() functions (house style: one message naming the
// key, its value and the allowed range).
#pragma once

#include <sstream>
#include <string>

namespace pl_slam {

/// "key=value must be in [lo, hi]" (or "(lo, hi]" with open_low) when v is outside the range
/// or NaN, else an empty string.
template <typename T>
std::string CheckRange(const char* key, T v, T lo, T hi, bool open_low = false) {
  const bool ok = open_low ? (v > lo && v <= hi) : (v >= lo && v <= hi);
  if (ok) return {};
  std::ostringstream os;
  os << key << "=" << v << " must be in " << (open_low ? "(" : "[") << lo << ", " << hi << "]";
  return os.str();
}

}  // namespace pl_slam
