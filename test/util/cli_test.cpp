#include <gtest/gtest.h>

#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

CommandLine Parse(std::vector<std::string> args) {
  std::vector<char*> argv;
  static std::string prog = "prog";
  argv.push_back(prog.data());
  for (auto& a : args) argv.push_back(a.data());
  return CommandLine(static_cast<int>(argv.size()), argv.data(), {"out", "n", "x"}, {"quiet"});
}

TEST(CommandLine, ParsesKeysFlagsAndPositionals) {
  const CommandLine cl = Parse({"input", "--out", "dir", "--n=5", "--quiet", "--x", "0.25"});
  ASSERT_EQ(cl.positional().size(), 1u);
  EXPECT_EQ(cl.positional()[0], "input");
  EXPECT_EQ(cl.Get("out", ""), "dir");
  EXPECT_EQ(cl.GetInt("n", 0), 5);
  EXPECT_DOUBLE_EQ(cl.GetDouble("x", 0.0), 0.25);
  EXPECT_TRUE(cl.Has("quiet"));
  EXPECT_EQ(cl.GetInt("missing", 7), 7);
}

TEST(CommandLine, RejectsUnknownOptionsAndMalformedValues) {
  EXPECT_THROW(Parse({"--bogus", "1"}), ConfigError);
  EXPECT_THROW(Parse({"--out"}), ConfigError);
  EXPECT_THROW(Parse({"--quiet=1"}), ConfigError);
  EXPECT_THROW(Parse({"--n", "5x"}).GetInt("n", 0), ConfigError);
  EXPECT_THROW(Parse({"--x", "nan"}).GetDouble("x", 0.0), ConfigError);
  // A repeated key would silently lose its first value.
  EXPECT_THROW(Parse({"--out", "a", "--out", "b"}), ConfigError);
  EXPECT_THROW(Parse({"--n=1", "--n", "2"}), ConfigError);
}

}  // namespace
}  // namespace pl_slam
