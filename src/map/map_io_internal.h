// Shared by the map file format (map_io.cpp) and its consistency checks (map_io_checks.cpp).
// Not part of the public API.
#pragma once

#include <cstdint>
#include <string>

#include "pl_slam/map/map_io.h"

namespace pl_slam {
namespace map_io_internal {

constexpr int kDescriptorBytes = 32;
constexpr int kMaxOctave = 64;

/// What is wrong, phrased to follow "map file <name> " (or "the map ").
struct FormatError {
  std::string problem;
};

[[noreturn]] inline void Fail(const std::string& problem) { throw FormatError{problem}; }

inline std::string Str(int64_t v) { return std::to_string(v); }

/// Throws FormatError("is invalid: ...") unless `c` is a map the Map could have built: finite
/// numbers, 32-byte descriptors, observations and keyframe landmark ids agreeing both ways, ids
/// below the counters, spanning tree and culled chains without cycles.
void ValidateContents(const MapContents& c);

}  // namespace map_io_internal
}  // namespace pl_slam
