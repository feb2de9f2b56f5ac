// Exceptions the core throws for bad input. Tools catch them at the top level and print the
// one-line message; nothing in the core calls exit() or abort() on bad data.
#pragma once

#include <stdexcept>
#include <string>

namespace pl_slam {

/// A file, folder, calibration or message that cannot be used. The message names the
/// offending file (or key) and what is wrong with it, on one line.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// A configuration value outside its allowed range or an unknown key.
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace pl_slam
