// A table of named option fields ("points.max_points", ...) over the options structs, so the
// YAML config, ROS parameters and command-line overrides all set options the same way:
// unknown keys and malformed values are refused with a message naming the key, and the
// effective configuration can be printed.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace pl_slam {

/// Named accessors into option structs. The table refers to the structs it was built over:
/// keep them alive while using it.
class OptionTable {
 public:
  /// Registers a field. `doc` is the one-line meaning shown by Describe().
  void Add(const std::string& key, int* field, const std::string& doc);
  void Add(const std::string& key, double* field, const std::string& doc);
  void Add(const std::string& key, bool* field, const std::string& doc);
  void Add(const std::string& key, std::string* field, const std::string& doc);
  /// Registers a field with its own parser (e.g. an enum); `set` throws ConfigError.
  void Add(const std::string& key, std::function<void(const std::string&)> set,
           std::function<std::string()> get, const std::string& doc);

  /// Sets `key` from text. Throws ConfigError "unknown key 'k'" or "k: 'v' is not a ...".
  void Set(const std::string& key, const std::string& value) const;
  /// Sets from "key=value". Throws ConfigError when malformed.
  void SetAssignment(const std::string& assignment) const;
  /// Sets from "k1=v1,k2=v2,..." (the `--set` of the command-line tools), in order.
  void SetAssignments(const std::string& list) const;
  bool Has(const std::string& key) const;
  /// Current value of `key` as text.
  std::string Get(const std::string& key) const;
  /// All keys, in registration order.
  std::vector<std::string> keys() const;
  /// "key: value  # doc" lines: the effective configuration.
  std::string Describe() const;

 private:
  struct Entry {
    std::string key, doc;
    std::function<void(const std::string&)> set;
    std::function<std::string()> get;
  };
  const Entry* Find(const std::string& key) const;
  std::vector<Entry> entries_;
};

/// Reads a YAML file of options into the table: nested maps are flattened with '.'
/// ("points: {max_points: 800}" sets "points.max_points"). Throws ConfigError naming the
/// file and the key for unknown keys, malformed values or an unreadable file.
void LoadYamlOptions(const std::string& path, const OptionTable& table);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
void LoadYamlOptionsFromString(const std::string& content, const std::string& path,
                               const OptionTable& table);

}  // namespace pl_slam
