// Image stamps in the nodelet: the backwards-stamp policy, exact integer stamps in saved
// trajectories, the start-up checks of the lifecycle options and the clean-up of temporary
// files a killed save left behind.
#include "pl_slam/ros/stamp_policy.h"

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pl_slam/io/trajectory.h"
#include "pl_slam/ros/stereo_slam_nodelet.h"

namespace pl_slam {
namespace ros_layer {
namespace {

constexpr int64_t kSecond = 1000000000;

TEST(StampPolicy, ParsesTheThreePolicies) {
  BackwardsStampPolicy p = BackwardsStampPolicy::kIgnore;
  ASSERT_TRUE(ParseBackwardsStampPolicy("reset_after", &p));
  EXPECT_EQ(p, BackwardsStampPolicy::kResetAfter);
  ASSERT_TRUE(ParseBackwardsStampPolicy("reset", &p));
  EXPECT_EQ(p, BackwardsStampPolicy::kReset);
  ASSERT_TRUE(ParseBackwardsStampPolicy("ignore", &p));
  EXPECT_EQ(p, BackwardsStampPolicy::kIgnore);
  EXPECT_FALSE(ParseBackwardsStampPolicy("Reset", &p));
  EXPECT_FALSE(ParseBackwardsStampPolicy("", &p));
}

TEST(StampPolicy, ForwardFirstAndRepeatedStamps) {
  for (auto policy : {BackwardsStampPolicy::kResetAfter, BackwardsStampPolicy::kReset,
                      BackwardsStampPolicy::kIgnore}) {
    EXPECT_EQ(ClassifyStamp(-1, 5, policy, kSecond), StampAction::kProcess);
    EXPECT_EQ(ClassifyStamp(5, 6, policy, kSecond), StampAction::kProcess);
    EXPECT_EQ(ClassifyStamp(5, 5, policy, kSecond), StampAction::kSkipRepeated);
  }
}

TEST(StampPolicy, ResetAfterSkipsJitterAndRestartsOnLargeJumps) {
  const int64_t last = 1000 * kSecond;
  const auto p = BackwardsStampPolicy::kResetAfter;
  EXPECT_EQ(ClassifyStamp(last, last - 1, p, kSecond), StampAction::kSkipBackwards);
  EXPECT_EQ(ClassifyStamp(last, last - kSecond, p, kSecond), StampAction::kSkipBackwards);
  EXPECT_EQ(ClassifyStamp(last, last - kSecond - 1, p, kSecond), StampAction::kRestart);
  EXPECT_EQ(ClassifyStamp(last, 0, p, kSecond), StampAction::kRestart);
}

TEST(StampPolicy, ResetAlwaysRestartsIgnoreNever) {
  const int64_t last = 1000 * kSecond;
  EXPECT_EQ(ClassifyStamp(last, last - 1, BackwardsStampPolicy::kReset, kSecond),
            StampAction::kRestart);
  EXPECT_EQ(ClassifyStamp(last, 0, BackwardsStampPolicy::kIgnore, kSecond),
            StampAction::kSkipBackwards);
}

TEST(ExactStamps, SavedTrajectoriesCarryTheImageStampsDigitForDigit) {
  // An EuRoC image stamp: as seconds in a double (ns * 1e-9) it is 1403636579.763555765.
  const std::vector<int64_t> stamps = {1403636579763555584, 1403636579813555456,
                                       1403636579863555584};
  ASSERT_NE(static_cast<int64_t>(std::llround(stamps[0] * 1e-9 * 1e9)), stamps[0])
      << "the test stamp must not survive a double, or it shows nothing";
  Trajectory traj;
  for (int64_t ns : stamps) {
    StampedPose p;
    p.t = static_cast<double>(ns) * 1e-9;
    p.t_ns = ns;  // what the core's trajectory carries
    traj.push_back(p);
  }
  const std::string tum = FormatTrajectory(traj, TrajectoryFormat::kTum);
  const std::string euroc = FormatTrajectory(traj, TrajectoryFormat::kEuroc);
  EXPECT_NE(tum.find("\n1403636579.763555584 "), std::string::npos) << tum;
  EXPECT_NE(tum.find("\n1403636579.813555456 "), std::string::npos) << tum;
  EXPECT_NE(euroc.find("\n1403636579763555584,"), std::string::npos) << euroc;
  EXPECT_NE(euroc.find("\n1403636579863555584,"), std::string::npos) << euroc;
  // Without exact stamps the seconds are still written (rounded).
  Trajectory plain = traj;
  for (auto& p : plain) p.t_ns = -1;
  EXPECT_NE(FormatTrajectory(plain, TrajectoryFormat::kTum).find("\n1403636579.763555765 "),
            std::string::npos);
  // Small stamps keep their leading zeros after the point.
  Trajectory small(1);
  small[0].t_ns = 12000000005;
  small[0].t = 12.000000005;
  EXPECT_NE(FormatTrajectory(small, TrajectoryFormat::kTum).find("\n12.000000005 "),
            std::string::npos);
}

TEST(LifecycleOptions, LocalisationOnlyNeedsAMapFile) {
  NodeletOptions o;
  EXPECT_EQ(o.Validate(), "");
  o.localization_only = true;
  EXPECT_NE(o.Validate().find("localization_only=true needs map_file"), std::string::npos)
      << o.Validate();
  o.map_file = "/tmp/room.plmap";
  EXPECT_EQ(o.Validate(), "");
}

TEST(LifecycleOptions, BackwardsStampPolicyIsChecked) {
  NodeletOptions o;
  EXPECT_EQ(o.backwards_stamp_policy, "reset_after");
  o.backwards_stamp_policy = "rewind";
  EXPECT_NE(o.Validate().find("backwards_stamp_policy='rewind'"), std::string::npos)
      << o.Validate();
  o.backwards_stamp_policy = "ignore";
  EXPECT_EQ(o.Validate(), "");
  o.backwards_stamp_reset_after = 0.0;
  EXPECT_NE(o.Validate().find("backwards_stamp_reset_after=0"), std::string::npos) << o.Validate();
}

TEST(LifecycleOptions, TheKeysAreInTheNodeletTable) {
  NodeletOptions o;
  const OptionTable table = MakeNodeletOptionTable(&o);
  table.Set("backwards_stamp_policy", "reset");
  table.Set("backwards_stamp_reset_after", "2.5");
  EXPECT_EQ(o.backwards_stamp_policy, "reset");
  EXPECT_DOUBLE_EQ(o.backwards_stamp_reset_after, 2.5);
}

TEST(StaleTemporaryFiles, ADeadWritersFileIsRemovedALiveOnesKept) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("pl_slam_stale_tmp_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // A pid that surely belongs to no process: a child that has exited and been reaped.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) ::_exit(0);
  ASSERT_EQ(::waitpid(child, nullptr, 0), child);
  const fs::path target = dir / "room.plmap";
  const fs::path dead = dir / (".room.plmap.tmp." + std::to_string(child) + ".0");
  const fs::path mine = dir / (".room.plmap.tmp." + std::to_string(::getpid()) + ".7");
  const fs::path parent = dir / (".room.plmap.tmp." + std::to_string(::getppid()) + ".0");
  const fs::path other = dir / (".other.plmap.tmp." + std::to_string(child) + ".0");
  for (const fs::path& p : {dead, mine, parent, other}) std::ofstream(p) << "partial";
  EXPECT_EQ(RemoveStaleTemporaryFiles(target.string()), 1);
  EXPECT_FALSE(fs::exists(dead)) << "the killed writer's temporary file is still there";
  EXPECT_TRUE(fs::exists(mine));
  EXPECT_TRUE(fs::exists(parent));
  EXPECT_TRUE(fs::exists(other));
  // The next save cleans up as well.
  std::ofstream(dead) << "partial";
  WriteFileAtomic(target.string(), "map");
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(target));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ros_layer
}  // namespace pl_slam
