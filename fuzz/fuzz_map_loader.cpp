// Fuzz target: the map file loader. The file ends with a checksum, which random mutations
// almost never keep valid, so each input is tried twice: as it is (checksum and header
// checks), and with the trailer rewritten to the right checksum so the section parsers and
// consistency checks behind it are reached.
#include <cstring>

#include "fuzz_util.h"
#include "pl_slam/map/map_io.h"

namespace {

void Load(const std::string& bytes) {
  pl_slam::Map map;
  pl_slam::fuzz::ExpectAcceptOrRefuse([&] {
    pl_slam::LoadMapFromBytes(bytes, "fuzz.plmap", &map);
    // A map that loaded must be consistent enough to use and to save again.
    (void)map.Snapshot();
    (void)pl_slam::SerializeMap(map);
  });
}

}  // namespace

namespace pl_slam {
namespace fuzz {

int MapLoader(const uint8_t* data, size_t size) {
  std::string bytes = pl_slam::fuzz::AsString(data, size);
  Load(bytes);
  if (bytes.size() >= 8) {
    const uint64_t sum = MapFileChecksum(bytes.data(), bytes.size() - 8);
    for (int i = 0; i < 8; ++i)  // little-endian, as the format stores every number
      bytes[bytes.size() - 8 + i] = static_cast<char>((sum >> (8 * i)) & 0xff);
    Load(bytes);
  }
  return 0;
}

}  // namespace fuzz
}  // namespace pl_slam

#ifndef PL_SLAM_FUZZ_NO_ENTRY
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pl_slam::fuzz::MapLoader(data, size);
}
#endif
