#include "pl_slam/eval/evaluate_cli.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "eval_test_util.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {
namespace {

namespace fs = std::filesystem;

// The EuRoC MH_01 cam0 extrinsics, as in its sensor.yaml.
constexpr const char* kSensorYaml = R"(# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
)";

class EvaluateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("pl_slam_cli_test_" + std::to_string(std::random_device{}()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  void WriteText(const std::string& name, const std::string& text) const {
    std::ofstream(Path(name)) << text;
  }

  int Run(const std::vector<std::string>& args) {
    out_.str("");
    err_.str("");
    return RunEvaluateCli(args, out_, err_);
  }

  fs::path dir_;
  std::ostringstream out_;
  std::ostringstream err_;
};

TEST_F(EvaluateCli, TumFilesTablePlotJson) {
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, 0.02);
  const Trajectory gt = testing::MakeLoop(200.0, 20.0);
  Trajectory est = testing::MakeLoop(20.0, 20.0);
  const SE3 T = testing::RandomSE3(rng);
  for (auto& p : est) {
    p.T_w_c = T * SE3(p.T_w_c.so3(),
                      p.T_w_c.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  WriteTrajectory(Path("gt.txt"), gt, TrajectoryFormat::kTum);
  WriteTrajectory(Path("est.txt"), est, TrajectoryFormat::kTum);
  const int rc = Run({"--est", Path("est.txt"), "--gt", Path("gt.txt"), "--plot", Path("p.png"),
                      "--json", Path("r.json"), "--name", "loop", "--rpe-lengths", "1,2"});
  EXPECT_EQ(rc, 0) << err_.str();
  const std::string out = out_.str();
  EXPECT_NE(out.find("ATE SE3"), std::string::npos) << out;
  EXPECT_NE(out.find("ATE Sim3"), std::string::npos) << out;
  EXPECT_NE(out.find("associated 401"), std::string::npos) << out;
  // Coverage defaults to the 200 Hz ground-truth stamps, hence the hint.
  EXPECT_NE(out.find("--frame-times"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(Path("p.png")));
  EXPECT_GT(fs::file_size(Path("p.png")), 10000u);
  std::ifstream json_in(Path("r.json"));
  const std::string json((std::istreambuf_iterator<char>(json_in)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"name\": \"loop\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"length_m\": 2"), std::string::npos) << json;

  // The ATE from the library for the same data: noise 2 cm per axis -> ~0.035 m.
  const EvaluationResult r = EvaluateTrajectory(est, gt, {});
  EXPECT_NEAR(r.ate.translation.rmse, 0.02 * std::sqrt(3.0), 0.01);
}

TEST_F(EvaluateCli, KittiWithTimesAndFrameTimes) {
  const Trajectory gt = testing::MakeLoop(10.0, 10.0, 0.0);
  WriteTrajectory(Path("gt_kitti.txt"), gt, TrajectoryFormat::kKitti);
  WriteTrajectory(Path("est.txt"), gt, TrajectoryFormat::kTum);
  std::string times;
  for (const auto& p : gt) times += std::to_string(p.t) + "\n";
  WriteText("times.txt", times);
  // Frame stamps every second (0..9 s): the estimate covers all of them.
  std::string frames = "# t [s]\n";
  for (int i = 0; i < 10; ++i) frames += std::to_string(i) + ".0\n";
  WriteText("frames.txt", frames);
  EXPECT_EQ(Run({"--est", Path("est.txt"), "--gt", Path("gt_kitti.txt"), "--gt-format", "kitti",
                 "--gt-times", Path("times.txt"), "--frame-times", Path("frames.txt"), "--align",
                 "none"}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("ATE none       rmse 0.0000 m"), std::string::npos) << out_.str();
  EXPECT_NE(out_.str().find("10 / 10 frames"), std::string::npos) << out_.str();
  // Without the stamps the KITTI ground truth is indexed 0, 1, 2, ... and the 10 Hz estimate
  // only meets it at whole seconds.
  EXPECT_EQ(Run({"--est", Path("est.txt"), "--gt", Path("gt_kitti.txt"), "--frame-times", "none"}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("associated 11 "), std::string::npos) << out_.str();
  EXPECT_NE(out_.str().find("coverage       n/a"), std::string::npos) << out_.str();
  // EuRoC-style nanosecond stamps keep their precision.
  std::string ns = "#timestamp [ns],filename\n";
  for (int i = 0; i < 10; ++i) ns += "10000000000" + std::to_string(i) + "00000000,x.png\n";
  WriteText("ns.csv", ns);
  const std::vector<double> t = ReadTimestamps(Path("ns.csv"));
  ASSERT_EQ(t.size(), 10u);
  EXPECT_NEAR(t[3], 10000000000.3, 1e-6);
}

TEST_F(EvaluateCli, EurocBodyGroundTruthWithSensorYaml) {
  WriteText("sensor.yaml", kSensorYaml);
  const SE3 T_B_C = ReadSensorYamlTBS(Path("sensor.yaml"));
  EXPECT_NEAR(T_B_C.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(T_B_C.rotation()(1, 0), 0.999557249008, 1e-6);

  // Body ground truth; the estimate tracks the camera.
  const Trajectory body = testing::MakeLoop(200.0, 10.0);
  const Trajectory cam = TransformTrajectory(testing::MakeLoop(20.0, 10.0), T_B_C);
  WriteTrajectory(Path("gt.csv"), body, TrajectoryFormat::kEuroc);
  WriteTrajectory(Path("est.txt"), cam, TrajectoryFormat::kTum);
  ASSERT_EQ(Run({"--est", Path("est.txt"), "--gt", Path("gt.csv"), "--t-bs", Path("sensor.yaml"),
                 "--align", "none", "--json", Path("r.json")}),
            0)
      << err_.str();
  std::ifstream in(Path("r.json"));
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string key = "\"translation_m\": {\"count\": 201, \"rmse\": ";
  const std::size_t at = json.find(key);
  ASSERT_NE(at, std::string::npos) << json;
  const double rmse = std::stod(json.substr(at + key.size()));
  EXPECT_LT(rmse, 1e-5);  // interpolated 200 Hz ground truth, no alignment

  // Without the extrinsics the camera offset (~7 cm) shows up.
  ASSERT_EQ(Run({"--est", Path("est.txt"), "--gt", Path("gt.csv"), "--align", "none"}), 0);
  EXPECT_EQ(out_.str().find("ATE none       rmse 0.0000 m"), std::string::npos) << out_.str();
  EXPECT_NE(out_.str().find("ATE none       rmse 0.0"), std::string::npos) << out_.str();

  // The same through --T_B_C.
  std::ostringstream m;
  m.precision(17);
  const Eigen::Matrix4d M = T_B_C.matrix();
  for (int k = 0; k < 16; ++k) m << M(k / 4, k % 4) << " ";
  ASSERT_EQ(Run({"--est", Path("est.txt"), "--gt", Path("gt.csv"), "--T_B_C", m.str(), "--align",
                 "none"}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("ATE none       rmse 0.0000 m"), std::string::npos) << out_.str();
}

TEST_F(EvaluateCli, BadInputIsExitOneWithOneLine) {
  WriteText("bad.txt", "1.0 2.0 three\n");
  WriteTrajectory(Path("gt.txt"), testing::MakeLoop(20.0, 2.0), TrajectoryFormat::kTum);
  EXPECT_EQ(Run({"--est", Path("bad.txt"), "--gt", Path("gt.txt"), "--est-format", "tum"}), 1);
  const std::string err = err_.str();
  EXPECT_EQ(err.rfind("pl_slam_evaluate: error: " + Path("bad.txt"), 0), 0u) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;

  EXPECT_EQ(Run({"--est", Path("missing.txt"), "--gt", Path("gt.txt")}), 1);
  EXPECT_NE(err_.str().find(Path("missing.txt")), std::string::npos) << err_.str();

  // No overlap in time: the estimate file is named.
  Trajectory late = testing::MakeLoop(20.0, 2.0, 5000.0);
  WriteTrajectory(Path("late.txt"), late, TrajectoryFormat::kTum);
  EXPECT_EQ(Run({"--est", Path("late.txt"), "--gt", Path("gt.txt")}), 1);
  EXPECT_EQ(err_.str().rfind("pl_slam_evaluate: error: " + Path("late.txt") + ": no estimate", 0),
            0u)
      << err_.str();

  WriteText("sensor.yaml", "T_BS:\n  data: [1, 0, 0]\n");
  EXPECT_EQ(Run({"--est", Path("gt.txt"), "--gt", Path("gt.txt"), "--t-bs", Path("sensor.yaml")}),
            1);
  EXPECT_NE(err_.str().find("16 numbers"), std::string::npos) << err_.str();

  // Unwritable plot.
  EXPECT_EQ(
      Run({"--est", Path("gt.txt"), "--gt", Path("gt.txt"), "--plot", Path("no_such_dir/p.png")}),
      1);
  EXPECT_NE(err_.str().find("no_such_dir"), std::string::npos) << err_.str();
}

TEST_F(EvaluateCli, UsageErrorsAreExitTwo) {
  EXPECT_EQ(Run({}), 2);
  EXPECT_NE(err_.str().find("usage:"), std::string::npos);
  EXPECT_EQ(Run({"--est", "a.txt"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--bogus"}), 2);
  EXPECT_NE(err_.str().find("--bogus"), std::string::npos);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--align", "affine"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--max-dt", "-1"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--max-dt"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--rpe-frames", "1,0"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--rpe-lengths", "1,x"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--est-format", "csv"}), 2);
  EXPECT_EQ(Run({"--est", "a", "--gt", "b", "--T_B_C", "1 2 3"}), 2);
  EXPECT_EQ(Run({"--help"}), 0);
  EXPECT_NE(out_.str().find("--rpe-lengths"), std::string::npos);

  const EvaluateCliArgs a =
      ParseEvaluateArgs({"--est", "e", "--gt", "g", "--align", "sim3", "--max-dt", "0.05",
                         "--rpe-frames", "1,5,20", "--rpe-lengths", "0.5 1"});
  EXPECT_EQ(a.options.alignment, AlignmentMode::kSim3);
  EXPECT_DOUBLE_EQ(a.options.max_dt, 0.05);
  EXPECT_EQ(a.options.rpe_frame_deltas, (std::vector<int>{1, 5, 20}));
  EXPECT_EQ(a.options.rpe_lengths, (std::vector<double>{0.5, 1.0}));
}

TEST(ParseRigidTransform16, RejectsNonRigid) {
  EXPECT_NO_THROW(ParseRigidTransform16("1 0 0 1  0 1 0 2  0 0 1 3  0 0 0 1", "T"));
  const SE3 T = ParseRigidTransform16("1,0,0,1, 0,1,0,2, 0,0,1,3, 0,0,0,1", "T");
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, 2, 3));
  EXPECT_THROW(ParseRigidTransform16("2 0 0 1  0 1 0 2  0 0 1 3  0 0 0 1", "T"), InputError);
  EXPECT_THROW(ParseRigidTransform16("1 0 0 1  0 1 0 2  0 0 1 3  0 0 1 1", "T"), InputError);
  EXPECT_THROW(ParseRigidTransform16("-1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1", "T"), InputError);
}

}  // namespace
}  // namespace eval
}  // namespace pl_slam
