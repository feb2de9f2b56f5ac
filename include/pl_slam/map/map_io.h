// Map files: save a map and load it back to continue tracking and mapping in it.
//
// Format version 1, every number little-endian:
//   header   "PLSLAMAP" | u32 format version | u32 byte-order marker 0x01020304 |
//            u64 payload bytes
//   payload  five sections in this order, each: 4-char tag | u64 body bytes | body
//            "META" next landmark id, keyframes inserted, culled point / line counts
//            "KFRM" keyframes: id, frame index, stamp, pose, parent, loop edges, point and line
//                   features with their 32-byte descriptors and landmark ids
//            "PNTS" point landmarks with their observations
//            "LINE" line landmarks with their observations
//            "CULL" culled keyframes: id, parent at culling time, T_parent_kf
//   trailer  u64 FNV-1a (64-bit) checksum of the header and the payload
// Poses are stored as qx qy qz qw tx ty tz. The reader bounds every count by the bytes that
// remain, so a corrupted count fails cleanly instead of asking for a huge allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "pl_slam/map/map.h"

namespace pl_slam {

/// The map file format version this build writes and reads.
constexpr uint32_t kMapFormatVersion = 1;

/// Writes everything needed to continue tracking and mapping in `map` (one consistent copy,
/// taken under the map lock) to `path`, atomically: temporary file in the same folder, fsync,
/// rename. Throws InputError naming the path and the reason when it cannot be written (an
/// existing file then stays as it was) or when the map is inconsistent (a file LoadMap would
/// reject is never written).
void SaveMap(const Map& map, const std::string& path);

/// Replaces the content of `map` with the map file at `path`. Everything is checked first
/// (format, sizes, checksum, finite numbers, observations matching the keyframes' landmark
/// ids); on any problem it throws InputError with a one-line message naming the file and what
/// is wrong, and `map` is left untouched. On success the content is replaced in one step under
/// the map lock and version() increases.
void LoadMap(const std::string& path, Map* map);

/// LoadMap() on the file content `bytes`; `name` names the source in error messages. Every
/// byte string either loads or throws InputError (the fuzzing entry point).
void LoadMapFromBytes(const std::string& bytes, const std::string& name, Map* map);

/// The bytes SaveMap() writes for `map` (throws InputError when the map is inconsistent).
std::string SerializeMap(const Map& map);

/// The file's checksum (FNV-1a, 64-bit) of `n` bytes: what the trailer holds for the header
/// and payload before it.
uint64_t MapFileChecksum(const char* data, size_t n);

}  // namespace pl_slam
