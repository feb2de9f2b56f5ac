#include "pl_slam/util/cli.h"

#include <cmath>
#include <cstdlib>
#include <iostream>

#include "pl_slam/util/error.h"

namespace pl_slam {

CommandLine::CommandLine(int argc, char** argv, const std::set<std::string>& keys,
                         const std::set<std::string>& flags) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) != 0 || a.size() == 2) {
      positional_.push_back(a);
      continue;
    }
    std::string name = a.substr(2), value;
    const auto eq = name.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    if (flags.count(name)) {
      if (inline_value) throw ConfigError("option --" + name + " takes no value");
      values_[name] = "1";
    } else if (keys.count(name)) {
      if (!inline_value) {
        if (i + 1 >= argc) throw ConfigError("option --" + name + " needs a value");
        value = argv[++i];
      }
      if (values_.count(name)) {
        // The first value would be silently lost.
        throw ConfigError("option --" + name + " given more than once" +
                          (name == "set" ? " (join the K=V pairs with commas)" : ""));
      }
      values_[name] = value;
    } else {
      throw ConfigError("unknown option --" + name);
    }
  }
}

std::string CommandLine::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

int CommandLine::GetInt(const std::string& name, int fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  const long v = std::strtol(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0' || v < -2147483647L || v > 2147483647L) {
    throw ConfigError("option --" + name + "='" + it->second + "' is not an integer");
  }
  return static_cast<int>(v);
}

double CommandLine::GetDouble(const std::string& name, double fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || !std::isfinite(v)) {
    throw ConfigError("option --" + name + "='" + it->second + "' is not a number");
  }
  return v;
}

int RunTool(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace pl_slam
