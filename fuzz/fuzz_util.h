// Shared by the libFuzzer targets (scripts/run_fuzzers.sh): every input must either be
// accepted or refused with the library's documented error types; anything else (a crash, a
// sanitizer report, another exception) is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace fuzz {

inline std::string AsString(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs `body`; InputError and ConfigError are the documented refusals. Any other exception
/// escapes and libFuzzer reports it as a crash (uncaught exception -> abort).
template <typename Body>
void ExpectAcceptOrRefuse(Body&& body) {
  try {
    body();
  } catch (const InputError&) {
  } catch (const ConfigError&) {
  }
}

/// The targets' bodies (fuzz/fuzz_*.cpp), also run by test/fuzz/fuzz_regression_test.cpp on
/// every committed input without libFuzzer.
int Config(const uint8_t* data, size_t size);
int MapLoader(const uint8_t* data, size_t size);
int Calibration(const uint8_t* data, size_t size);
int Trajectory(const uint8_t* data, size_t size);

}  // namespace fuzz
}  // namespace pl_slam
