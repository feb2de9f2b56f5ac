// SequenceOptions: validation names the bad key and its range; text setting rejects unknown
// keys and malformed values; constructors refuse invalid input with ConfigError.
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam::sim {
namespace {

TEST(SequenceOptionsTest, DefaultsAreValid) {
  const SequenceOptions o;
  EXPECT_EQ(o.Validate(), "");
  EXPECT_EQ(o.scene, SceneKind::kRoom);
  EXPECT_EQ(o.width, 752);
  EXPECT_EQ(o.height, 480);
  EXPECT_EQ(o.rate_hz, 20.0);
  EXPECT_EQ(o.baseline, 0.11);
}

TEST(SequenceOptionsTest, ValidateNamesTheBadKey) {
  struct Case {
    std::string key;
    std::function<void(SequenceOptions*)> spoil;
  };
  const std::vector<Case> cases = {
      {"num_frames", [](SequenceOptions* o) { o->num_frames = -1; }},
      {"rate_hz", [](SequenceOptions* o) { o->rate_hz = 0.0; }},
      {"rate_hz", [](SequenceOptions* o) { o->rate_hz = std::nan(""); }},
      {"width", [](SequenceOptions* o) { o->width = 4; }},
      {"height", [](SequenceOptions* o) { o->height = 100000; }},
      {"focal", [](SequenceOptions* o) { o->focal = -450.0; }},
      {"baseline", [](SequenceOptions* o) { o->baseline = 0.0; }},
      {"noise_sigma", [](SequenceOptions* o) { o->noise_sigma = -1.0; }},
      {"exposure_gain_amplitude", [](SequenceOptions* o) { o->exposure_gain_amplitude = 1.5; }},
      {"exposure_offset_amplitude", [](SequenceOptions* o) { o->exposure_offset_amplitude = -3; }},
      {"exposure_period_s", [](SequenceOptions* o) { o->exposure_period_s = 0.0; }},
      {"start_time_s", [](SequenceOptions* o) { o->start_time_s = -5.0; }},
      {"edge_supersampling", [](SequenceOptions* o) { o->edge_supersampling = 0; }},
  };
  for (const Case& c : cases) {
    SequenceOptions o;
    c.spoil(&o);
    const std::string msg = o.Validate();
    EXPECT_EQ(msg.rfind(c.key + "=", 0), 0u)
        << "message '" << msg << "' should start with " << c.key;
    EXPECT_NE(msg.find("must be in"), std::string::npos) << msg;
    try {
      SyntheticSequence seq(o);
      ADD_FAILURE() << "constructor accepted bad " << c.key;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(c.key), std::string::npos) << e.what();
    }
  }
}

TEST(SequenceOptionsTest, SetParsesKnownKeysAndRejectsOthers) {
  SequenceOptions o;
  o.Set("scene", "corridor");
  o.Set("num_frames", "12");
  o.Set("rate_hz", "15.5");
  o.Set("exposure_change", "true");
  o.Set("seed", "42");
  o.Set("noise_sigma", "0");
  EXPECT_EQ(o.scene, SceneKind::kCorridor);
  EXPECT_EQ(o.num_frames, 12);
  EXPECT_EQ(o.rate_hz, 15.5);
  EXPECT_TRUE(o.exposure_change);
  EXPECT_EQ(o.seed, 42u);
  EXPECT_EQ(o.noise_sigma, 0.0);
  EXPECT_EQ(o.Validate(), "");
  EXPECT_NE(o.ToString().find("scene: corridor"), std::string::npos);

  EXPECT_THROW(o.Set("colour", "red"), ConfigError);
  EXPECT_THROW(o.Set("num_frames", "twelve"), ConfigError);
  EXPECT_THROW(o.Set("num_frames", "12x"), ConfigError);
  EXPECT_THROW(o.Set("seed", "-1"), ConfigError);
  EXPECT_THROW(o.Set("exposure_change", "maybe"), ConfigError);
  EXPECT_THROW(o.Set("scene", "kitchen"), ConfigError);
  try {
    o.Set("colour", "red");
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("colour"), std::string::npos) << e.what();
  }
}

// ToString() lists every option in a form Set() reads back to the same options.
TEST(SequenceOptionsTest, ToStringRoundTripsThroughSet) {
  SequenceOptions a;
  a.scene = SceneKind::kFastTurn;
  a.num_frames = 99;
  a.rate_hz = 12.5;
  a.exposure_change = true;
  a.seed = 123456789012345ULL;
  a.start_time_s = 1403636579.763555584;  // EuRoC-like: needs all digits
  a.baseline = 0.11;
  SequenceOptions b;
  std::istringstream lines(a.ToString());
  std::string line;
  int keys = 0;
  while (std::getline(lines, line)) {
    const std::size_t colon = line.find(": ");
    ASSERT_NE(colon, std::string::npos) << line;
    b.Set(line.substr(0, colon), line.substr(colon + 2));
    ++keys;
  }
  EXPECT_EQ(keys, 22);
  EXPECT_EQ(b.ToString(), a.ToString());
  EXPECT_EQ(b.scene, SceneKind::kFastTurn);
  EXPECT_EQ(b.seed, 123456789012345ULL);
  EXPECT_EQ(b.start_time_s, a.start_time_s);
  EXPECT_NE(a.ToString().find("baseline: 0.11\n"), std::string::npos);
}

TEST(SequenceOptionsTest, CustomWorldNeedsWorldAndPoses) {
  auto world = std::make_shared<World>();
  Trajectory one(1);
  EXPECT_THROW(SyntheticSequence(SequenceOptions(), nullptr, one), ConfigError);
  EXPECT_THROW(SyntheticSequence(SequenceOptions(), world, Trajectory()), ConfigError);
  SyntheticSequence ok(SequenceOptions(), world, one);
  EXPECT_EQ(ok.size(), 1u);
}

}  // namespace
}  // namespace pl_slam::sim
