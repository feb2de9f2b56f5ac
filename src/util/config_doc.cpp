#include "pl_slam/util/config_doc.h"

#include <sstream>
#include <vector>

namespace pl_slam {
namespace {

// The page's head: where the keys are read and how they are checked.
constexpr char kIntro[] = R"md(# Configuration

<!-- Generated from the option table: do not edit. After adding or changing an option, run
     `bash scripts/gen_config_doc.sh`; the test ConfigDoc.MatchesTheOptionTable fails until then. -->

Every option of the pipeline, with its default and its meaning. The same keys are read from

- a YAML file: `config/*.yaml` for the nodelet, `pl_slam_offline --config FILE.yaml`; nested
  maps are flattened with `.` (`tracker: {points: {max_points: 800}}` sets
  `tracker.points.max_points`);
- the nodelet's ROS parameters, nested the same way under its private namespace;
- `pl_slam_offline --set key=value,...`, and `--mode points|lines|points_lines` (the same as
  `--set tracker.mode=...`).

They are checked at start-up: an unknown key, a malformed value or a value out of its range
stops the nodelet or the runner with one error naming the key and its allowed range. The
effective configuration is logged at start; `pl_slam_offline --print-config` prints it (with
`--config` and `--set` applied). The nodelet's own keys (frames, synchronisation, camera,
publishing rates, map file) are in [ros.md](ros.md#parameters).
)md";

struct Row {
  std::string key, value, doc;
};

// Table cells: a '|' would end the cell.
std::string Cell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

std::string Prefix(const std::string& key, int parts) {
  size_t pos = 0;
  for (int i = 0; i < parts; ++i) {
    pos = key.find('.', pos);
    if (pos == std::string::npos) return key;
    if (i + 1 < parts) ++pos;
  }
  return key.substr(0, pos);
}

int Parts(const std::string& key) {
  int n = 1;
  for (char c : key) n += c == '.';
  return n;
}

// The rows of Describe(), whose lines are "key: value  # doc" in registration order; the key
// and value are known, so whatever follows them is the doc, '#' or not.
std::vector<Row> Rows(const OptionTable& table) {
  std::vector<Row> rows;
  std::istringstream lines(table.Describe());
  std::string line;
  for (const std::string& key : table.keys()) {
    Row row{key, table.Get(key), ""};
    const std::string head = key + ": " + row.value + "  # ";
    // A value or doc spanning lines would desynchronise keys and lines: look the key up.
    while (std::getline(lines, line)) {
      if (line.compare(0, head.size(), head) == 0) {
        row.doc = line.substr(head.size());
        break;
      }
    }
    rows.push_back(row);
  }
  return rows;
}

void WriteTable(const std::vector<Row>& rows, std::ostringstream& os) {
  os << "| key | default | meaning |\n|---|---|---|\n";
  for (const Row& r : rows) {
    os << "| `" << Cell(r.key) << "` | "
       << (r.value.empty() ? "(empty)" : "`" + Cell(r.value) + "`") << " | " << Cell(r.doc)
       << " |\n";
  }
}

}  // namespace

std::string OptionTableMarkdown(const OptionTable& table) {
  std::ostringstream os;
  os << kIntro;

  const std::vector<Row> rows = Rows(table);
  std::string group, subgroup;
  std::vector<Row> pending;
  const auto flush = [&] {
    if (!pending.empty()) WriteTable(pending, os);
    pending.clear();
  };
  for (const Row& r : rows) {
    const std::string g = Prefix(r.key, 1);
    const std::string sub = Parts(r.key) > 2 ? Prefix(r.key, 2) : g;
    if (g != group) {
      flush();
      os << "\n## " << g << "\n\n";
      group = g;
      subgroup = g;
    }
    if (sub != subgroup) {
      flush();
      os << "\n### " << sub << "\n\n";
      subgroup = sub;
    }
    pending.push_back(r);
  }
  flush();
  return os.str();
}

}  // namespace pl_slam
