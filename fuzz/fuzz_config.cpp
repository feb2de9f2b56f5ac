// Fuzz target: the YAML options parser and validation (config files, ROS parameters and
// --set assignments all go through the option table).
#include "fuzz_util.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/option_table.h"

namespace pl_slam {
namespace fuzz {

int Config(const uint8_t* data, size_t size) {
  const std::string text = pl_slam::fuzz::AsString(data, size);
  {
    pl_slam::SystemOptions options;
    const pl_slam::OptionTable table = pl_slam::MakeOptionTable(&options);
    pl_slam::fuzz::ExpectAcceptOrRefuse([&] {
      pl_slam::LoadYamlOptionsFromString(text, "fuzz.yaml", table);
      (void)options.Validate();
      (void)table.Describe();
    });
  }
  {
    // The same bytes as one command-line assignment ("key=value").
    pl_slam::SystemOptions options;
    const pl_slam::OptionTable table = pl_slam::MakeOptionTable(&options);
    pl_slam::fuzz::ExpectAcceptOrRefuse([&] {
      table.SetAssignment(text);
      (void)options.Validate();
    });
  }
  return 0;
}

}  // namespace fuzz
}  // namespace pl_slam

#ifndef PL_SLAM_FUZZ_NO_ENTRY
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return pl_slam::fuzz::Config(data, size);
}
#endif
