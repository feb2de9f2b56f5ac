// Tiny command-line parsing shared by the package's executables: "--key value" pairs and
// "--flag" switches, with a clear message for unknown or malformed options.
#pragma once

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace pl_slam {

/// Parsed command line: positional arguments and --options.
class CommandLine {
 public:
  /// Parses argv. `flags` take no value, `keys` take exactly one. Throws ConfigError on an
  /// unknown option, a missing value or a key given twice.
  CommandLine(int argc, char** argv, const std::set<std::string>& keys,
              const std::set<std::string>& flags);

  const std::vector<std::string>& positional() const { return positional_; }
  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  std::string Get(const std::string& name, const std::string& fallback) const;
  /// Parses an integer value; throws ConfigError naming the option when malformed.
  int GetInt(const std::string& name, int fallback) const;
  /// Parses a floating-point value; throws ConfigError naming the option when malformed.
  double GetDouble(const std::string& name, double fallback) const;

 private:
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
};

/// Runs a tool's body and turns escaping errors into one line on stderr and an exit code:
/// ConfigError (bad usage or options) -> "<tool>: error: ..." and 2, any other exception
/// (bad input files) -> 1. Returns the body's own code otherwise.
int RunTool(const char* tool, const std::function<int()>& body);

}  // namespace pl_slam
