#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "pl_slam/util/error.h"
#include "pl_slam/util/option_table.h"

namespace pl_slam {
namespace {

struct Opts {
  int n = 3;
  double x = 0.5;
  bool flag = false;
  std::string name = "a";
};

OptionTable Table(Opts* o) {
  OptionTable t;
  t.Add("group.n", &o->n, "an int");
  t.Add("group.x", &o->x, "a double");
  t.Add("flag", &o->flag, "a bool");
  t.Add("name", &o->name, "a string");
  return t;
}

TEST(OptionTable, SetsGetsAndDescribes) {
  Opts o;
  const OptionTable t = Table(&o);
  t.Set("group.n", "7");
  t.SetAssignment("group.x=2.5");
  t.Set("flag", "true");
  t.Set("name", "hello");
  EXPECT_EQ(o.n, 7);
  EXPECT_DOUBLE_EQ(o.x, 2.5);
  EXPECT_TRUE(o.flag);
  EXPECT_EQ(o.name, "hello");
  EXPECT_EQ(t.Get("group.n"), "7");
  EXPECT_NE(t.Describe().find("group.x: 2.5  # a double"), std::string::npos);
}

// The command-line tools' --set: comma-separated assignments, applied in order.
TEST(OptionTable, SetsACommaSeparatedListOfAssignments) {
  Opts o;
  const OptionTable t = Table(&o);
  t.SetAssignments("group.n=9,name=b,group.n=4");
  EXPECT_EQ(o.n, 4);
  EXPECT_EQ(o.name, "b");
  EXPECT_THROW(t.SetAssignments("flag=true,novalue"), ConfigError);
  EXPECT_THROW(t.SetAssignments("group.n=1,typo=2"), ConfigError);
}

TEST(OptionTable, RefusesUnknownKeysAndMalformedValuesNamingThem) {
  Opts o;
  const OptionTable t = Table(&o);
  auto message = [&](const std::string& k, const std::string& v) {
    try {
      t.Set(k, v);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("group.m", "1").find("unknown key 'group.m'"), std::string::npos);
  EXPECT_NE(message("group.n", "1.5").find("group.n"), std::string::npos);
  EXPECT_NE(message("group.x", "abc").find("group.x"), std::string::npos);
  EXPECT_NE(message("flag", "yes please").find("flag"), std::string::npos);
  EXPECT_THROW(t.SetAssignment("novalue"), ConfigError);
  EXPECT_EQ(o.n, 3);  // nothing changed by the failed calls
}

TEST(OptionTable, LoadsNestedYamlAndReportsFileAndKey) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("pl_slam_opt_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string good = (dir / "good.yaml").string(), bad = (dir / "bad.yaml").string(),
                    broken = (dir / "broken.yaml").string();
  std::ofstream(good) << "group:\n  n: 11\n  x: 0.25\nflag: true\n";
  std::ofstream(bad) << "group:\n  n: 1\n  typo: 2\n";
  std::ofstream(broken) << "group: [1, 2\n";
  Opts o;
  const OptionTable t = Table(&o);
  LoadYamlOptions(good, t);
  EXPECT_EQ(o.n, 11);
  EXPECT_DOUBLE_EQ(o.x, 0.25);
  EXPECT_TRUE(o.flag);
  try {
    LoadYamlOptions(bad, t);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.yaml"), std::string::npos) << m;
    EXPECT_NE(m.find("group.typo"), std::string::npos) << m;
  }
  EXPECT_THROW(LoadYamlOptions(broken, t), ConfigError);
  EXPECT_THROW(LoadYamlOptions((dir / "missing.yaml").string(), t), ConfigError);
  EXPECT_THROW(LoadYamlOptions(dir.string(), t), ConfigError);  // a folder
  std::ofstream(dir / "empty.yaml") << "";
  EXPECT_NO_THROW(LoadYamlOptions((dir / "empty.yaml").string(), t));  // sets nothing
  std::filesystem::remove_all(dir);
}

// Found by fuzzing (fuzz/corpus/config/crash-complex-key.yaml): a complex or null YAML key
// made yaml-cpp throw its own exception through the parser instead of a ConfigError.
TEST(OptionTable, ComplexAndNullKeysAreRefusedWithTheLine) {
  Opts o;
  const OptionTable t = Table(&o);
  for (const char* text :
       {"group:\n  ? {a: b}\n  : 1\n", "? [n]\n: 2\n", "group:\n  ? \n  : 1\n"}) {
    try {
      LoadYamlOptionsFromString(text, "cfg.yaml", t);
      FAIL() << text;
    } catch (const ConfigError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("cfg.yaml:"), std::string::npos) << m;
      EXPECT_NE(m.find("not a plain name"), std::string::npos) << m;
    }
  }
  EXPECT_EQ(o.n, 3);
}

}  // namespace
}  // namespace pl_slam
