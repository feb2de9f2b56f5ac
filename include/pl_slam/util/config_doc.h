// The reference page of the pipeline options, docs/configuration.md, rendered from the same
// option table the config files, ROS parameters, `--set` and `--print-config` use, so the page
// cannot drift from the code (test/util/config_doc_test.cpp compares the two).
#pragma once

#include <string>

#include "pl_slam/util/option_table.h"

namespace pl_slam {

/// The whole of docs/configuration.md for `table` (built over default options): an
/// introduction, then one section per top-level group ("tracker", "mapping", ...) and one
/// table of key, default and meaning per second-level group. Printed by
/// `pl_slam_offline --print-config-markdown`.
std::string OptionTableMarkdown(const OptionTable& table);

}  // namespace pl_slam
