// SystemOptions for tests that run the whole system with loop closing: mapping in line
// (deterministic, bit-identical run to run) and the package's vocabulary.
#pragma once

#include <string>

#include "pl_slam/system/slam_system.h"

namespace pl_slam {
namespace testing_util {

inline SystemOptions SequentialWithVocabulary() {
  SystemOptions o;
  o.mapping.threaded = false;
  o.loop.vocabulary = std::string(PL_SLAM_SOURCE_DIR) + "/vocabulary";
  return o;
}

}  // namespace testing_util
}  // namespace pl_slam
