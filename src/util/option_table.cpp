#include "pl_slam/util/option_table.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "pl_slam/util/error.h"

namespace pl_slam {

namespace {

std::string FormatDouble(double v) {
  std::ostringstream os;
  os << std::setprecision(10) << v;
  return os.str();
}

}  // namespace

void OptionTable::Add(const std::string& key, int* field, const std::string& doc) {
  Add(
      key,
      [key, field](const std::string& v) {
        char* end = nullptr;
        errno = 0;
        const long x = std::strtol(v.c_str(), &end, 10);
        if (v.empty() || *end != '\0' || errno != 0 || x < -2147483647L || x > 2147483647L)
          throw ConfigError(key + ": '" + v + "' is not an integer");
        *field = static_cast<int>(x);
      },
      [field] { return std::to_string(*field); }, doc);
}

void OptionTable::Add(const std::string& key, double* field, const std::string& doc) {
  Add(
      key,
      [key, field](const std::string& v) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end != '\0' || !std::isfinite(x))
          throw ConfigError(key + ": '" + v + "' is not a number");
        *field = x;
      },
      [field] { return FormatDouble(*field); }, doc);
}

void OptionTable::Add(const std::string& key, bool* field, const std::string& doc) {
  Add(
      key,
      [key, field](const std::string& v) {
        if (v == "true" || v == "1" || v == "True")
          *field = true;
        else if (v == "false" || v == "0" || v == "False")
          *field = false;
        else
          throw ConfigError(key + ": '" + v + "' is not true or false");
      },
      [field] { return std::string(*field ? "true" : "false"); }, doc);
}

void OptionTable::Add(const std::string& key, std::string* field, const std::string& doc) {
  Add(
      key, [field](const std::string& v) { *field = v; }, [field] { return *field; }, doc);
}

void OptionTable::Add(const std::string& key, std::function<void(const std::string&)> set,
                      std::function<std::string()> get, const std::string& doc) {
  entries_.push_back({key, doc, std::move(set), std::move(get)});
}

const OptionTable::Entry* OptionTable::Find(const std::string& key) const {
  for (const Entry& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

void OptionTable::Set(const std::string& key, const std::string& value) const {
  const Entry* e = Find(key);
  if (!e) throw ConfigError("unknown key '" + key + "'");
  e->set(value);
}

void OptionTable::SetAssignment(const std::string& assignment) const {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ConfigError("'" + assignment + "' is not key=value");
  Set(assignment.substr(0, eq), assignment.substr(eq + 1));
}

void OptionTable::SetAssignments(const std::string& list) const {
  std::stringstream ss(list);
  std::string assignment;
  while (std::getline(ss, assignment, ',')) SetAssignment(assignment);
}

bool OptionTable::Has(const std::string& key) const { return Find(key) != nullptr; }

std::string OptionTable::Get(const std::string& key) const {
  const Entry* e = Find(key);
  if (!e) throw ConfigError("unknown key '" + key + "'");
  return e->get();
}

std::vector<std::string> OptionTable::keys() const {
  std::vector<std::string> k;
  for (const Entry& e : entries_) k.push_back(e.key);
  return k;
}

std::string OptionTable::Describe() const {
  std::ostringstream os;
  for (const Entry& e : entries_) os << e.key << ": " << e.get() << "  # " << e.doc << "\n";
  return os.str();
}

namespace {

void Flatten(const YAML::Node& node, const std::string& prefix, const std::string& path,
             const OptionTable& table) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      // A complex key ("? {a: b}: c") or a null one cannot name an option (found by fuzzing:
      // as<std::string>() threw yaml-cpp's own exception through the parser).
      if (!kv.first.IsScalar()) {
        throw ConfigError(path + ":" + std::to_string(kv.first.Mark().line + 1) + ": a key" +
                          (prefix.empty() ? std::string() : " under '" + prefix + "'") +
                          " is not a plain name");
      }
      const std::string k = kv.first.Scalar();
      Flatten(kv.second, prefix.empty() ? k : prefix + "." + k, path, table);
    }
    return;
  }
  if (!node.IsScalar()) throw ConfigError(path + ": key '" + prefix + "' must be a single value");
  try {
    table.Set(prefix, node.Scalar());
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

}  // namespace

void LoadYamlOptions(const std::string& path, const OptionTable& table) {
  std::error_code ec;
  std::ifstream in(path, std::ios::binary);
  if (!in || std::filesystem::is_directory(path, ec))
    throw ConfigError(path + ": cannot read the config file");
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw ConfigError(path + ": cannot read the config file");
  LoadYamlOptionsFromString(content, path, table);
}

void LoadYamlOptionsFromString(const std::string& content, const std::string& path,
                               const OptionTable& table) {
  YAML::Node root;
  try {
    root = YAML::Load(content);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML (" + e.msg + " at line " +
                      std::to_string(e.mark.line + 1) + ")");
  }
  if (root.IsNull()) return;  // an empty file sets nothing
  if (!root.IsMap()) throw ConfigError(path + ": the config must be a map of keys to values");
  try {
    Flatten(root, "", path, table);
  } catch (const YAML::Exception& e) {  // anything yaml-cpp still throws: one line, not a crash
    throw ConfigError(path + ": not a valid config (" + e.msg + " at line " +
                      std::to_string(e.mark.line + 1) + ")");
  }
}

}  // namespace pl_slam
