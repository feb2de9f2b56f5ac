// Trajectory file formats: round trips at full precision, atomic writes, and one-line
// "file:line: what" errors on malformed content.
#include "test_util/datasets.h"
#include "test_util/temp_dir.h"
#include "pl_slam/io/trajectory.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;
using testing_util::DatasetsDir;
using testing_util::WriteText;

// A fresh folder under the system temp directory, removed with everything in it.
// Each test's files go in its own folder, named after this file.
class TempDir : public testing_util::TempDir {
 public:
  TempDir() : testing_util::TempDir("traj_test") {}
};

Trajectory RandomTrajectory(int n, double t0, double dt, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  Trajectory traj;
  for (int i = 0; i < n; ++i) {
    StampedPose p;
    p.t = t0 + dt * i;
    p.T_w_c = SE3(Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)),
                  Eigen::Vector3d(u(rng), u(rng), u(rng)) * 17.0);
    traj.push_back(p);
  }
  return traj;
}

// Poses equal up to the quaternion sign.
void ExpectSamePoses(const Trajectory& a, const Trajectory& b, double tol_t, double tol_pose) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i].t, b[i].t, tol_t) << "pose " << i;
    EXPECT_LE((a[i].T_w_c.translation() - b[i].T_w_c.translation()).cwiseAbs().maxCoeff(), tol_pose)
        << "pose " << i;
    EXPECT_LE((a[i].T_w_c.rotation() - b[i].T_w_c.rotation()).cwiseAbs().maxCoeff(), tol_pose)
        << "pose " << i;
  }
}

// Expects fn() to throw InputError whose message contains every string of `parts`.
template <typename Fn>
void ExpectInputError(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << "message is not one line: " << what;
    for (const auto& p : parts)
      EXPECT_NE(what.find(p), std::string::npos) << "'" << p << "' not in: " << what;
  }
}

TEST(TrajectoryFormatTest, ParsesNamesCaseInsensitively) {
  EXPECT_EQ(ParseTrajectoryFormat("tum"), TrajectoryFormat::kTum);
  EXPECT_EQ(ParseTrajectoryFormat("KITTI"), TrajectoryFormat::kKitti);
  EXPECT_EQ(ParseTrajectoryFormat("EuRoC"), TrajectoryFormat::kEuroc);
  ExpectInputError([] { ParseTrajectoryFormat("bogus"); }, {"bogus", "tum, kitti or euroc"});
}

TEST(TrajectoryIoTest, TumRoundTripIsExactForPosesAndNanosecondForTimes) {
  TempDir dir;
  const Trajectory traj = RandomTrajectory(50, 1403636584.763555584, 0.05, 1);
  const std::string path = dir.File("traj.txt");
  WriteTrajectory(path, traj, TrajectoryFormat::kTum);
  const Trajectory back = ReadTumTrajectory(path);
  ExpectSamePoses(traj, back, 0.0, 1e-15);  // %.9f is finer than the double spacing at 1.4e9 s
  EXPECT_EQ(GuessTrajectoryFormat(path), TrajectoryFormat::kTum);
  // Small times keep 9 decimals.
  const Trajectory small = RandomTrajectory(5, 0.123456789, 0.1, 2);
  WriteTrajectory(path, small, TrajectoryFormat::kTum);
  ExpectSamePoses(small, ReadTrajectory(path, TrajectoryFormat::kTum), 1e-9, 1e-15);
}

TEST(TrajectoryIoTest, KittiRoundTripUsesGivenTimes) {
  TempDir dir;
  const Trajectory traj = RandomTrajectory(20, 0.0, 0.1, 3);
  const std::string path = dir.File("poses.txt");
  WriteTrajectory(path, traj, TrajectoryFormat::kKitti);
  EXPECT_EQ(GuessTrajectoryFormat(path), TrajectoryFormat::kKitti);
  const Trajectory by_index = ReadKittiTrajectory(path);
  ASSERT_EQ(by_index.size(), traj.size());
  EXPECT_DOUBLE_EQ(by_index[7].t, 7.0);
  std::vector<double> times;
  for (const auto& p : traj) times.push_back(p.t);
  ExpectSamePoses(traj, ReadKittiTrajectory(path, times), 0.0, 1e-12);
  times.pop_back();
  ExpectInputError([&] { ReadKittiTrajectory(path, times); }, {"poses.txt", "20 poses", "19"});
}

TEST(TrajectoryIoTest, EurocRoundTripWritesIntegerNanoseconds) {
  TempDir dir;
  Trajectory traj = RandomTrajectory(30, 0.0, 0.005, 4);
  for (std::size_t i = 0; i < traj.size(); ++i) {
    traj[i].t = static_cast<double>(1403636584763555584LL + 5000000LL * i) * 1e-9;
  }
  const std::string path = dir.File("data.csv");
  WriteTrajectory(path, traj, TrajectoryFormat::kEuroc);
  std::ifstream in(path);
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(header.rfind("#timestamp", 0), 0u);
  EXPECT_EQ(first.substr(0, first.find(',')).find_first_not_of("0123456789"), std::string::npos)
      << first;
  EXPECT_EQ(GuessTrajectoryFormat(path), TrajectoryFormat::kEuroc);
  ExpectSamePoses(traj, ReadEurocTrajectory(path), 1e-6, 1e-15);
}

TEST(TrajectoryIoTest, EurocReaderTakesFirstEightOfMoreColumns) {
  TempDir dir;
  const std::string path = dir.File("gt.csv");
  WriteText(path,
            "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
            "q_RS_y [], q_RS_z [], v_x, v_y, v_z\r\n"
            "1403636583763559936,4.704289,-1.764755,0.778351,0.545651,-0.168396,-0.814859,"
            "-0.099678,0,0,0\r\n"
            "1403636583768559872, 4.704469, -1.764865, 0.775402, 0.544855, -0.168788, "
            "-0.815374, -0.099163, 0, 0, 0\r\n");
  const Trajectory traj = ReadEurocTrajectory(path);
  ASSERT_EQ(traj.size(), 2u);
  EXPECT_NEAR(traj[0].t, 1403636583.763559936, 1e-6);
  EXPECT_NEAR(traj[1].T_w_c.translation().z(), 0.775402, 1e-12);
  const Eigen::Quaterniond q = traj[0].T_w_c.so3();
  EXPECT_NEAR(std::abs(q.w()), 0.545651, 1e-5);
  EXPECT_NEAR(q.x() / q.w(), -0.168396 / 0.545651, 1e-9);
}

TEST(TrajectoryIoTest, MalformedContentNamesFileAndLine) {
  TempDir dir;
  const std::string tum = dir.File("bad.tum");
  WriteText(tum, "# comment\n0.0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(tum); }, {"bad.tum:3:", "expected 8 numbers"});
  WriteText(tum, "0.0 0 0 0 0 0 0 1\n0.1 0 abc 0 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(tum); }, {"bad.tum:2:", "'abc'"});
  WriteText(tum, "0.0 0 0 0 0 0 0 0\n");
  ExpectInputError([&] { ReadTumTrajectory(tum); }, {"bad.tum:1:", "quaternion"});
  WriteText(tum, "1.0 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(tum); }, {"bad.tum:2:", "earlier"});
  WriteText(tum, "0.0 nan 0 0 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(tum); }, {"bad.tum:1:", "'nan'"});

  const std::string kitti = dir.File("poses.txt");
  WriteText(kitti, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  ExpectInputError([&] { ReadKittiTrajectory(kitti); }, {"poses.txt:2:", "12 numbers"});
  WriteText(kitti, "1 0 0 0 0 1 0 0 0 0 2 0\n");
  ExpectInputError([&] { ReadKittiTrajectory(kitti); }, {"poses.txt:1:", "rotation"});

  const std::string euroc = dir.File("data.csv");
  WriteText(euroc, "#t,x,y,z,qw,qx,qy,qz\n1000,0,0,0,1,0,0,0\n2000,0,0,0,1,0\n");
  ExpectInputError([&] { ReadEurocTrajectory(euroc); }, {"data.csv:3:", "8"});
  WriteText(euroc, "1.5,0,0,0,1,0,0,0\n");
  ExpectInputError([&] { ReadEurocTrajectory(euroc); }, {"data.csv:1:", "nanosecond"});

  ExpectInputError([&] { ReadTumTrajectory(dir.File("missing.txt")); }, {"missing.txt"});
}

TEST(TrajectoryIoTest, WriteIsAtomicAndLeavesNoTemporaryFiles) {
  TempDir dir;
  const std::string path = dir.File("out.txt");
  WriteText(path, "old content\n");
  const Trajectory traj = RandomTrajectory(10, 0.0, 0.1, 5);
  WriteTrajectory(path, traj, TrajectoryFormat::kTum);
  ExpectSamePoses(traj, ReadTumTrajectory(path), 1e-9, 1e-15);
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(e.path().filename(), "out.txt");
  }
  EXPECT_EQ(files, 1);

  WriteFileAtomic(path, "");
  EXPECT_EQ(fs::file_size(path), 0u);
  EXPECT_TRUE(ReadTumTrajectory(path).empty());

  const std::string nowhere = dir.File("no_such_folder/out.txt");
  ExpectInputError([&] { WriteTrajectory(nowhere, traj, TrajectoryFormat::kTum); },
                   {"no_such_folder/out.txt", "cannot write"});
}

TEST(TrajectoryIoTest, TransformTrajectoryRightMultiplies) {
  const Trajectory traj = RandomTrajectory(4, 0.0, 1.0, 6);
  const SE3 T(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(0.1, -0.2, 0.3));
  const Trajectory out = TransformTrajectory(traj, T);
  ASSERT_EQ(out.size(), traj.size());
  for (std::size_t i = 0; i < traj.size(); ++i) {
    EXPECT_EQ(out[i].t, traj[i].t);
    const Eigen::Matrix4d expected = traj[i].T_w_c.matrix() * T.matrix();
    EXPECT_LE((out[i].T_w_c.matrix() - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
}

}  // namespace
}  // namespace pl_slam
