// docs/configuration.md is rendered from the option table; these tests fail when an option is
// added, removed or changed and the page was not regenerated (bash scripts/gen_config_doc.sh).
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/config_doc.h"
#include "pl_slam/util/option_table.h"

namespace pl_slam {
namespace {

constexpr char kRegenerate[] =
    "regenerate it with `bash scripts/gen_config_doc.sh` (or `pl_slam_offline "
    "--print-config-markdown > docs/configuration.md` after a build) and commit it";

TEST(ConfigDoc, MatchesTheOptionTable) {
  SystemOptions options;
  const OptionTable table = MakeOptionTable(&options);
  const std::string expected = OptionTableMarkdown(table);
  const std::string path = std::string(PL_SLAM_SOURCE_DIR) + "/docs/configuration.md";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << path << " is missing: " << kRegenerate;
  const std::string actual((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (actual == expected) return;
  std::istringstream a(actual), e(expected);
  std::string line_a, line_e;
  int line = 0;
  while (true) {
    ++line;
    const bool more_a = static_cast<bool>(std::getline(a, line_a));
    const bool more_e = static_cast<bool>(std::getline(e, line_e));
    if (!more_a) line_a = "(end of file)";
    if (!more_e) line_e = "(end of page)";
    if (line_a != line_e || !more_a || !more_e) break;
  }
  FAIL() << "docs/configuration.md differs from the option table at line " << line
         << ":\n  file:  " << line_a << "\n  table: " << line_e << "\n"
         << kRegenerate;
}

TEST(ConfigDoc, EveryKeyHasOneRowWithItsDefaultAndMeaning) {
  SystemOptions options;
  const OptionTable table = MakeOptionTable(&options);
  const std::string page = OptionTableMarkdown(table);
  for (const std::string& key : table.keys()) {
    const std::string row = "| `" + key + "` | ";
    const size_t at = page.find(row);
    ASSERT_NE(at, std::string::npos) << key;
    EXPECT_EQ(page.find(row, at + 1), std::string::npos) << key << " listed twice";
    const std::string line = page.substr(at, page.find('\n', at) - at);
    EXPECT_EQ(line.find(" |  |"), std::string::npos) << "no meaning: " << line;
  }
}

struct Opts {
  int n = 3;
  std::string mode = "a|b";
  std::string empty;
};

TEST(ConfigDoc, GroupsByPrefixAndEscapesCells) {
  Opts o;
  OptionTable t;
  t.Add("top.n", &o.n, "an int");
  t.Add("top.sub.mode", &o.mode, "one of a|b");
  t.Add("other.empty", &o.empty, "a string");
  const std::string page = OptionTableMarkdown(t);
  EXPECT_NE(page.find("\n## top\n\n| key | default | meaning |\n|---|---|---|\n"
                      "| `top.n` | `3` | an int |\n"),
            std::string::npos)
      << page;
  EXPECT_NE(page.find("\n### top.sub\n\n| key | default | meaning |\n|---|---|---|\n"
                      "| `top.sub.mode` | `a\\|b` | one of a\\|b |\n"),
            std::string::npos)
      << page;
  EXPECT_NE(page.find("\n## other\n\n| key | default | meaning |\n|---|---|---|\n"
                      "| `other.empty` | (empty) | a string |\n"),
            std::string::npos)
      << page;
}

}  // namespace
}  // namespace pl_slam
